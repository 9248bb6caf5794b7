"""Residual vector quantisation with EMA codebooks.

Each layer quantises what the previous layers left over (the residual); the quantised output is the sum
of the chosen codes. Codebooks are not trained by gradients: they follow an exponential moving average of
the vectors assigned to them (decay 0.99), start from data vectors on the first batch, and codes whose EMA
count drops below a threshold are re-initialised from vectors of the current batch (dead-code reset).
Gradients reach the encoder through the straight-through estimator; a commitment loss pulls encoder
outputs toward their codes.
"""
from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn as nn
import torch.nn.functional as F


@dataclass
class QuantizedResult:
    quantized: torch.Tensor       # (N, D) sum of codes, straight-through in training
    codes: torch.Tensor           # (N, L) int64 code per layer; -1 for layers dropped
    commit_loss: torch.Tensor     # scalar, mean over the used layers
    perplexity: torch.Tensor      # (L,) per layer (0 for dropped layers)
    usage: torch.Tensor           # (L,) fraction of codes used in this batch
    num_layers: int               # layers actually used


class EMAQuantizer(nn.Module):
    def __init__(self, codebook_size: int, dim: int, decay: float = 0.99, dead_threshold: float = 1.0,
                 eps: float = 1e-5):
        super().__init__()
        self.codebook_size, self.dim, self.decay, self.dead_threshold, self.eps = (
            codebook_size, dim, decay, dead_threshold, eps)
        self.register_buffer("codebook", torch.zeros(codebook_size, dim))
        self.register_buffer("cluster_size", torch.zeros(codebook_size))
        self.register_buffer("embed_sum", torch.zeros(codebook_size, dim))
        self.register_buffer("initted", torch.zeros((), dtype=torch.bool))
        self.num_resets = 0  # dead codes re-initialised since the counter was last read

    @staticmethod
    def _sample(x: torch.Tensor, n: int) -> torch.Tensor:
        """n rows of x (with replacement and a little noise when x has fewer rows)."""
        if x.shape[0] >= n:
            return x[torch.randperm(x.shape[0], device=x.device)[:n]]
        idx = torch.randint(0, x.shape[0], (n,), device=x.device)
        return x[idx] + 0.01 * x.std() * torch.randn(n, x.shape[1], device=x.device)

    @torch.no_grad()
    def init_from(self, x: torch.Tensor) -> None:
        self.codebook.copy_(self._sample(x, self.codebook_size))
        self.cluster_size.fill_(1.0)
        self.embed_sum.copy_(self.codebook)
        self.initted.fill_(True)

    def assign(self, x: torch.Tensor) -> torch.Tensor:
        """(N, D) -> (N,) index of the nearest code (squared Euclidean)."""
        d = (x.pow(2).sum(1, keepdim=True) - 2 * x @ self.codebook.t() + self.codebook.pow(2).sum(1)[None])
        return d.argmin(dim=1)

    @torch.no_grad()
    def ema_update(self, x: torch.Tensor, codes: torch.Tensor) -> None:
        onehot = F.one_hot(codes, self.codebook_size).type(x.dtype)   # (N, K)
        self.cluster_size.mul_(self.decay).add_(onehot.sum(0), alpha=1 - self.decay)
        self.embed_sum.mul_(self.decay).add_(onehot.t() @ x, alpha=1 - self.decay)
        n = self.cluster_size.sum()
        smoothed = (self.cluster_size + self.eps) / (n + self.codebook_size * self.eps) * n  # Laplace
        self.codebook.copy_(self.embed_sum / smoothed[:, None])
        dead = self.cluster_size < self.dead_threshold
        if dead.any():
            self.num_resets += int(dead.sum())
            fresh = self._sample(x, int(dead.sum()))
            self.codebook[dead] = fresh
            self.embed_sum[dead] = fresh
            self.cluster_size[dead] = 1.0

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(N, D) -> (codes (N,), quantized (N, D) without straight-through)."""
        if self.training and not bool(self.initted):
            self.init_from(x.detach())
        codes = self.assign(x.detach())
        if self.training:
            self.ema_update(x.detach(), codes)
        return codes, F.embedding(codes, self.codebook)


class ResidualVQ(nn.Module):
    def __init__(self, num_quantizers: int, codebook_size: int, dim: int, decay: float = 0.99,
                 dead_threshold: float = 1.0, dropout: float = 0.0):
        super().__init__()
        self.layers = nn.ModuleList(EMAQuantizer(codebook_size, dim, decay, dead_threshold)
                                    for _ in range(num_quantizers))
        self.dropout = dropout

    @property
    def num_quantizers(self) -> int:
        return len(self.layers)

    def forward(self, x: torch.Tensor, num_layers: int | None = None) -> QuantizedResult:
        """x: (N, D). `num_layers` uses only the first k layers; in training, quantizer dropout picks k."""
        L = self.num_quantizers
        k = num_layers or L
        if self.training and num_layers is None and self.dropout > 0 and torch.rand(()) < self.dropout:
            k = int(torch.randint(1, L + 1, ()))
        residual = x
        total = torch.zeros_like(x)
        codes = torch.full((x.shape[0], L), -1, dtype=torch.long, device=x.device)
        perplexity = torch.zeros(L, device=x.device)
        usage = torch.zeros(L, device=x.device)
        commit = x.new_zeros(())
        for i, layer in enumerate(self.layers[:k]):
            c, q = layer(residual)
            codes[:, i] = c
            commit = commit + F.mse_loss(residual, q.detach())
            residual = residual - q.detach()
            total = total + q
            counts = torch.bincount(c, minlength=layer.codebook_size).float()
            p = counts / counts.sum()
            perplexity[i] = torch.exp(-(p * torch.log(p + 1e-10)).sum())
            usage[i] = (counts > 0).float().mean()
        quantized = x + (total - x).detach()  # straight-through estimator
        return QuantizedResult(quantized, codes, commit / k, perplexity, usage, k)

    def codes_to_quantized(self, codes: torch.Tensor) -> torch.Tensor:
        """(N, L) codes (-1 = layer unused) -> (N, D) sum of the chosen codes."""
        out = None
        for i, layer in enumerate(self.layers):
            if i >= codes.shape[1]:
                break
            c = codes[:, i]
            q = F.embedding(c.clamp_min(0), layer.codebook) * (c >= 0).unsqueeze(1).to(layer.codebook)
            out = q if out is None else out + q
        return out
