"""EMAGE's skeleton-convolution motion encoder, the feature extractor of the paper's FGD.

The paper's FGD (and EMAGE's) is the Frechet distance between latents of a pretrained skeleton-conv
autoencoder, published as `AESKConv_240_100.bin`. Those weights are not reachable from this project's
machines; this module rebuilds the encoder's architecture so that a user who has the file gets the paper's
feature space:

    model = SkeletonConvEncoder()                      # 55 SMPL-X joints, 4 layers, channel growth 1,1,2,1
    load_emage_weights(model, "AESKConv_240_100.bin")  # encoder part of the published checkpoint
    z = model(rot6d)                                   # (B, T, 330) -> (B, T/16, 240)

Architecture (facts of the published model, our implementation):
- The skeleton is a list of edges: a virtual edge (0, 55) for the root, then (parent(j), j) for j = 1..54, so
  edge j carries joint j's rotation; the input is 55 x 6D (first two rows of R), joint-major, un-normalised.
- Four layers; layer i maps `base_i` channels per edge to `base_{i+1}` (bases 6, 6, 6, 12, 12) with a
  skeleton residual block: [masked conv k=4 stride 2 pad 1 (zeros) -> GroupNorm(10)] + masked conv k=1
  stride 2 (shortcut), summed, then skeleton mean-pooling and tanh. A masked conv lets an output edge see
  only edges within distance 2 (edges are adjacent when they share a joint).
- Pooling: the edge graph is cut into chains between branching joints (depth-first from joint 0, children in
  edge order); within a chain, edges are merged in pairs (an odd chain keeps its first edge alone). The last
  layer merges each whole chain into one edge: 20 chains x 12 channels = 240 features per latent frame,
  one latent frame per 16 motion frames.
- State-dict names follow the published file (`encoder.layers.{i}.0.residual.0.weight|bias|mask`,
  `...residual.1` GroupNorm, `...shortcut`, `...common.0.weight` pooling), so the file loads strictly; its
  decoder and variational heads are not needed for FGD and are ignored.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F

from ..errors import CheckpointError, InputError
from ..motion.skeleton import PARENTS
from ..safe_load import load_tensors

GROWTH = (1, 1, 2, 1)
LATENT_DIM = 240
STRIDE = 16


def skeleton_edges(parents: tuple[int, ...] = PARENTS) -> list[tuple[int, int]]:
    """Edge j carries joint j: a virtual root edge (0, J), then (parent, child)."""
    return [(0, len(parents))] + [(parents[j], j) for j in range(1, len(parents))]


def edge_neighbours(edges: list[tuple[int, int]], max_dist: int = 2) -> list[list[int]]:
    """For each edge, the edges within `max_dist` hops in the edge graph (sharing a joint = 1 hop)."""
    n = len(edges)
    adj = [[j for j in range(n) if j != i and set(edges[i]) & set(edges[j])] for i in range(n)]
    out = []
    for i in range(n):
        dist = {i: 0}
        frontier = [i]
        for d in range(1, max_dist + 1):
            frontier = [k for f in frontier for k in adj[f] if k not in dist]
            for k in frontier:
                dist[k] = d
        out.append(sorted(dist))
    return out


def pooling_groups(edges: list[tuple[int, int]], last: bool) -> tuple[list[list[int]], list[tuple[int, int]]]:
    """Chains of edges between branching joints, merged pairwise (or whole when `last`).
    Returns (groups of edge indices, the pooled edges)."""
    degree: dict[int, int] = {}
    for a, b in edges:
        degree[a] = degree.get(a, 0) + 1
        degree[b] = degree.get(b, 0) + 1
    chains: list[list[int]] = []

    def walk(joint: int, chain: list[int]) -> None:
        if degree[joint] > 2 and joint != 0:
            chains.append(chain)
            chain = []
        if degree[joint] == 1:
            chains.append(chain)
            return
        for idx, (a, b) in enumerate(edges):
            if a == joint:
                walk(b, chain + [idx])

    walk(0, [])
    groups: list[list[int]] = []
    new_edges: list[tuple[int, int]] = []
    for chain in chains:
        if last:
            groups.append(chain)
            continue
        if len(chain) % 2:
            groups.append([chain[0]])
            new_edges.append(edges[chain[0]])
            chain = chain[1:]
        for a, b in zip(chain[::2], chain[1::2]):
            groups.append([a, b])
            new_edges.append((edges[a][0], edges[b][1]))
    return groups, new_edges


class MaskedSkeletonConv(nn.Module):
    """Conv1d over (B, edges x C_in, T) whose output edge i sees only its neighbour edges' channels."""

    def __init__(self, neighbours: list[list[int]], c_in: int, c_out: int, kernel: int, stride: int, padding: int):
        super().__init__()
        n = len(neighbours)
        self.stride, self.padding = stride, padding
        mask = torch.zeros(n * c_out, n * c_in, kernel)
        for i, nb in enumerate(neighbours):
            cols = [k * c_in + c for k in nb for c in range(c_in)]
            mask[i * c_out:(i + 1) * c_out, cols] = 1
        self.mask = nn.Parameter(mask, requires_grad=False)
        w = torch.empty(n * c_out, n * c_in, kernel)
        b = torch.empty(n * c_out)
        for i, nb in enumerate(neighbours):      # init each output edge from its own fan-in
            fan_in = len(nb) * c_in * kernel
            bound = 1 / math.sqrt(fan_in)
            w[i * c_out:(i + 1) * c_out].uniform_(-bound, bound)
            b[i * c_out:(i + 1) * c_out].uniform_(-bound, bound)
        self.weight = nn.Parameter(w * mask)
        self.bias = nn.Parameter(b)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = F.pad(x, (self.padding, self.padding))
        return F.conv1d(x, self.weight * self.mask, self.bias, self.stride)


class SkeletonPool(nn.Module):
    """Mean over the edges of each group, as a fixed (groups x C, edges x C) matrix."""

    def __init__(self, groups: list[list[int]], num_edges: int, channels: int):
        super().__init__()
        w = torch.zeros(len(groups) * channels, num_edges * channels)
        for g, members in enumerate(groups):
            for e in members:
                for c in range(channels):
                    w[g * channels + c, e * channels + c] = 1.0 / len(members)
        self.weight = nn.Parameter(w, requires_grad=False)

    def forward(self, x: torch.Tensor) -> torch.Tensor:           # (B, E*C, T) -> (B, G*C, T)
        return torch.matmul(self.weight, x)


class SkeletonResidualDown(nn.Module):
    def __init__(self, edges: list[tuple[int, int]], c_in: int, c_out: int, last: bool):
        super().__init__()
        nb = edge_neighbours(edges, 2)
        n = len(edges)
        self.residual = nn.Sequential(MaskedSkeletonConv(nb, c_in, c_out, 4, 2, 1), nn.GroupNorm(10, n * c_out))
        self.shortcut = MaskedSkeletonConv(nb, c_in, c_out, 1, 2, 0)
        groups, self.new_edges = pooling_groups(edges, last)
        self.num_out_edges = len(groups)
        layers: list[nn.Module] = [SkeletonPool(groups, n, c_out)] if len(groups) != n else []
        self.common = nn.Sequential(*layers, nn.Tanh())

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.common(self.residual(x) + self.shortcut(x))


class SkeletonConvEncoder(nn.Module):
    """(B, T, 6 * joints) 6D rotations -> (B, T / 16, latent) (240 for SMPL-X's 55 joints)."""

    def __init__(self, parents: tuple[int, ...] = PARENTS, growth: tuple[int, ...] = GROWTH, base: int = 6):
        super().__init__()
        edges = skeleton_edges(parents)
        bases = [base]
        for g in growth:
            bases.append(bases[-1] * g)
        self.layers = nn.ModuleList()
        for i in range(len(growth)):
            block = SkeletonResidualDown(edges, bases[i], bases[i + 1], last=i == len(growth) - 1)
            self.layers.append(nn.Sequential(block))
            n_out = block.num_out_edges
            edges = block.new_edges
        self.in_dim = 6 * len(parents)
        self.latent_dim = n_out * bases[-1]
        self.stride = 2 ** len(growth)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = x.transpose(1, 2)                                          # (B, 330, T)
        for layer in self.layers:
            h = layer(h)
        return h.transpose(1, 2)                                       # (B, T/16, 240)


def load_emage_weights(model: SkeletonConvEncoder, path_or_state: str | Path | dict) -> SkeletonConvEncoder:
    """Load the encoder part of EMAGE's `AESKConv_240_100.bin` (or any state dict in its naming: a plain
    state dict or one under 'model_state', with or without DataParallel's 'module.' prefix)."""
    state = path_or_state
    if not isinstance(state, dict):
        state = load_tensors(Path(path_or_state), map_location="cpu")     # tensors only: no code from the file
    if "model_state" in state:
        state = state["model_state"]
    enc = {}
    for k, v in state.items():
        k = k[len("module."):] if k.startswith("module.") else k
        if k.startswith("encoder."):
            enc[k[len("encoder."):]] = v
    if not enc:
        raise CheckpointError("no 'encoder.*' weights found: not an EMAGE skeleton-conv autoencoder checkpoint")
    try:
        model.load_state_dict(enc, strict=True)
    except RuntimeError as exc:
        raise CheckpointError(f"the checkpoint does not match the skeleton-conv encoder architecture: {exc}") from None
    return model.eval()


@torch.no_grad()
def emage_features(model: SkeletonConvEncoder, rot6d: np.ndarray | torch.Tensor) -> np.ndarray:
    """(T, 330) 6D rotations of one sequence -> (T // 16, 240) latents (trailing frames cropped)."""
    x = torch.as_tensor(np.asarray(rot6d, np.float32))
    T = x.shape[0] // model.stride * model.stride
    if T == 0:
        raise InputError(f"a sequence needs at least {model.stride} frames for EMAGE features")
    return model(x[None, :T])[0].numpy().astype(np.float64)
