"""The reference's per-region RVQ-VAE: conv encoder (x4 down), residual VQ with projected codebooks, decoder.

Layout follows the released state dicts (`encoder.model.*`, `decoder.model.*`) so weights load by name.
The quantizer's effective codebook of layer q is Linear_q(codebook_q) (an `embedding_proj` trained with it);
at inference we store that product once (`codes`, (Q, K, d)).
"""
from __future__ import annotations

import torch
import torch.nn as nn
import torch.nn.functional as F

from .config import RVQConfig


class ResBlock(nn.Module):
    """ReLU -> Conv(k3, dilation d) -> ReLU -> Conv 1x1 -> + input."""

    def __init__(self, width: int, dilation: int):
        super().__init__()
        self.conv1 = nn.Conv1d(width, width, 3, 1, dilation, dilation)
        self.conv2 = nn.Conv1d(width, width, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:  # (B, W, T)
        return x + self.conv2(F.relu(self.conv1(F.relu(x))))


class ResStack(nn.Module):
    def __init__(self, width: int, depth: int, growth: int):
        super().__init__()
        # the reference builds dilations growth**0.. and reverses them: 9, 3, 1 in encoder and decoder
        self.model = nn.Sequential(*[ResBlock(width, growth ** i) for i in reversed(range(depth))])

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.model(x)


def _encoder(c: RVQConfig) -> nn.Sequential:
    layers: list[nn.Module] = [nn.Conv1d(c.input_dim, c.width, 3, 1, 1), nn.ReLU()]
    for _ in range(c.down):
        layers.append(nn.Sequential(nn.Conv1d(c.width, c.width, 4, 2, 1),
                                    ResStack(c.width, c.depth, c.dilation_growth)))
    layers.append(nn.Conv1d(c.width, c.code_dim, 3, 1, 1))
    return nn.Sequential(*layers)


def _decoder(c: RVQConfig) -> nn.Sequential:
    layers: list[nn.Module] = [nn.Conv1d(c.code_dim, c.width, 3, 1, 1), nn.ReLU()]
    for _ in range(c.down):
        layers.append(nn.Sequential(ResStack(c.width, c.depth, c.dilation_growth), nn.Upsample(scale_factor=2.0),
                                    nn.Conv1d(c.width, c.width, 3, 1, 1)))
    layers += [nn.Conv1d(c.width, c.width, 3, 1, 1), nn.ReLU(), nn.Conv1d(c.width, c.input_dim, 3, 1, 1)]
    return nn.Sequential(*layers)


class Wrap(nn.Module):
    def __init__(self, seq: nn.Sequential):
        super().__init__()
        self.model = seq


class ReferenceRVQ(nn.Module):
    """encode: (B, T, D) normalised motion -> (B, T/4, d) continuous latent; decode: re-quantise + decode."""

    def __init__(self, cfg: RVQConfig):
        super().__init__()
        self.cfg = cfg
        self.encoder = Wrap(_encoder(cfg))
        self.decoder = Wrap(_decoder(cfg))
        self.register_buffer("codes", torch.zeros(cfg.num_quantizers, cfg.num_codes, cfg.code_dim))  # projected

    def encode(self, x: torch.Tensor) -> torch.Tensor:
        return self.encoder.model(x.transpose(1, 2)).transpose(1, 2)  # (B, T/4, d)

    def quantize(self, z: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """z (B, N, d) -> (quantised sum (B, N, d), indices (B, N, Q)); nearest code per residual layer."""
        B, N, d = z.shape
        residual = z.reshape(B * N, d)
        out = torch.zeros_like(residual)
        idx = []
        for q in range(self.cfg.num_quantizers):
            cb = self.codes[q]                                                     # (K, d)
            dist = residual.pow(2).sum(-1, keepdim=True) - 2 * residual @ cb.T + cb.pow(2).sum(-1)
            i = dist.argmin(-1)
            chosen = residual + (cb[i] - residual)  # the reference's straight-through sum, same rounding
            residual = residual - chosen
            out = out + chosen
            idx.append(i)
        return out.reshape(B, N, d), torch.stack(idx, -1).reshape(B, N, -1)

    def decode_codes(self, zq: torch.Tensor) -> torch.Tensor:
        return self.decoder.model(zq.transpose(1, 2)).transpose(1, 2)  # (B, T, D)

    def decode(self, z: torch.Tensor) -> torch.Tensor:
        """Continuous latent (B, N, d) -> motion (B, 4N, D), as the reference's latent2origin."""
        return self.decode_codes(self.quantize(z)[0])
