"""Transformer building blocks: embeddings, attention with rotary positions, cross/spatial-temporal blocks.

The Fast* subclasses are what kernels.accelerate swaps in for inference: the same function with fewer passes over
memory (rotations applied in place to the packed projection, cross-attention folded into the speech side once per
window); with kernels.fast_path() off they compute exactly their parent's forward."""
from __future__ import annotations

import functools
import math

import torch
import torch.nn as nn
import torch.nn.functional as F

from ..kernels import fast_path, faster_version_of


def sinusoidal(t: torch.Tensor, dim: int, max_period: float = 1e4) -> torch.Tensor:
    """(B,) values in [0, 1] (not rescaled) -> (B, dim)."""
    half = dim // 2
    freqs = torch.exp(-math.log(max_period) * torch.arange(half, device=t.device, dtype=torch.float32) / half)
    args = t.float()[:, None] * freqs[None]
    return torch.cat([torch.cos(args), torch.sin(args)], dim=-1)


@functools.lru_cache(maxsize=32)
def rotary_freqs(n: int, head_dim: int, device: torch.device, base: float = 1e4) -> torch.Tensor:
    """(n, head_dim / 2) complex rotations e^{i pos * base^(-2k / head_dim)}; cached (inference calls the same
    shapes at every step). Read-only: never modify the returned tensor in place. Made outside inference mode even
    when first asked for inside it, so that training in the same process can still use the cached table."""
    with torch.inference_mode(False):
        inv = 1.0 / base ** (torch.arange(0, head_dim, 2, device=device, dtype=torch.float32) / head_dim)
        ang = torch.arange(n, device=device, dtype=torch.float32)[:, None] * inv[None]   # (n, hd/2)
        return torch.polar(torch.ones_like(ang), ang)


def apply_rotary(x: torch.Tensor, freqs: torch.Tensor) -> torch.Tensor:
    """x: (..., n, hd); rotates each interleaved pair (x[2k], x[2k+1]) by its position's angle, as one complex
    product: (x1 + i x2) e^{i a} = (x1 cos a - x2 sin a) + i (x1 sin a + x2 cos a)."""
    xc = torch.view_as_complex(x.float().reshape(*x.shape[:-1], -1, 2).contiguous())
    return torch.view_as_real(xc * freqs).flatten(-2).type_as(x)


@functools.lru_cache(maxsize=32)
def rotary_freqs_qk(n: int, heads: int, head_dim: int, device: torch.device) -> torch.Tensor:
    """(n, heads * head_dim) complex: `rotary_freqs` laid out like the query and key halves of a packed (q, k, v)
    projection seen as complex pairs (the same table for every head, for q and for k). Read-only; like
    `rotary_freqs`, never an inference tensor."""
    with torch.inference_mode(False):
        return rotary_freqs(n, head_dim, device).repeat(1, 2 * heads)


class DropPath(nn.Module):
    def __init__(self, p: float):
        super().__init__()
        self.p = p

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if not self.training or self.p == 0:
            return x
        keep = torch.rand(x.shape[0], *([1] * (x.ndim - 1)), device=x.device) >= self.p
        return x * keep / (1 - self.p)


class SelfAttention(nn.Module):
    def __init__(self, dim: int, heads: int, rotary: bool):
        super().__init__()
        self.heads, self.rotary = heads, rotary
        self.qkv = nn.Linear(dim, 3 * dim)
        self.out = nn.Linear(dim, dim)

    def forward(self, x: torch.Tensor) -> torch.Tensor:  # (N, L, dim)
        N, L, C = x.shape
        q, k, v = self.qkv(x).reshape(N, L, 3, self.heads, C // self.heads).permute(2, 0, 3, 1, 4)  # (N, h, L, hd)
        if self.rotary:
            freqs = rotary_freqs(L, C // self.heads, x.device)
            q, k = apply_rotary(q, freqs), apply_rotary(k, freqs)
        y = F.scaled_dot_product_attention(q, k, v)
        return self.out(y.transpose(1, 2).reshape(N, L, C))


class CrossAttention(nn.Module):
    """Queries from gesture tokens, keys/values from speech features. K/V can be precomputed once per clip
    (`kv`), since the speech condition does not change across sampling steps."""

    def __init__(self, dim: int, cond_dim: int, heads: int):
        super().__init__()
        self.heads = heads
        self.q = nn.Linear(dim, dim)
        self.kv = nn.Linear(cond_dim, 2 * dim)
        self.out = nn.Linear(dim, dim)

    def project_kv(self, cond: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        N, S, _ = cond.shape
        C = self.q.out_features
        k, v = self.kv(cond).reshape(N, S, 2, self.heads, C // self.heads).permute(2, 0, 3, 1, 4)
        return k, v  # (N, h, S, hd)

    def forward(self, x: torch.Tensor, kv: tuple[torch.Tensor, torch.Tensor]) -> torch.Tensor:
        N, L, C = x.shape
        q = self.q(x).reshape(N, L, self.heads, C // self.heads).transpose(1, 2)
        y = F.scaled_dot_product_attention(q, kv[0], kv[1])
        return self.out(y.transpose(1, 2).reshape(N, L, C))


class MLP(nn.Sequential):
    def __init__(self, dim: int, hidden: int):
        super().__init__(nn.Linear(dim, hidden), nn.GELU(), nn.Linear(hidden, dim))


class CrossBlock(nn.Module):
    """Pre-LN cross-attention of every (region, frame) token to the speech features, then an MLP.
    Regions and frames stay separate tokens (the reference's `.view` mixed three frames into one)."""

    def __init__(self, dim: int, cond_dim: int, heads: int, ffn: int, drop_path: float):
        super().__init__()
        self.norm1, self.norm2 = nn.LayerNorm(dim), nn.LayerNorm(dim)
        self.norm_c = nn.LayerNorm(cond_dim)
        self.attn = CrossAttention(dim, cond_dim, heads)
        self.mlp = MLP(dim, ffn)
        self.drop = DropPath(drop_path)

    def kv(self, cond: torch.Tensor) -> tuple[torch.Tensor, ...]:
        return self.attn.project_kv(self.norm_c(cond))

    def forward(self, x: torch.Tensor, kv) -> torch.Tensor:  # x: (B, R*t, dim)
        x = x + self.drop(self.attn(self.norm1(x), kv))
        return x + self.drop(self.mlp(self.norm2(x)))


class STBlock(nn.Module):
    """Spatial attention across regions within a frame, then temporal attention across frames within a
    region (rotary positions), then an FFN; pre-LN residuals (paper order: spatial, then temporal)."""

    def __init__(self, dim: int, heads: int, ffn: int, drop_path: float):
        super().__init__()
        self.norm_s, self.norm_t, self.norm_f = nn.LayerNorm(dim), nn.LayerNorm(dim), nn.LayerNorm(dim)
        self.spatial = SelfAttention(dim, heads, rotary=False)   # regions carry a learned embedding
        self.temporal = SelfAttention(dim, heads, rotary=True)
        self.mlp = MLP(dim, ffn)
        self.drop = DropPath(drop_path)

    def forward(self, x: torch.Tensor) -> torch.Tensor:  # (B, R, t, dim)
        B, R, t, C = x.shape
        s = x.transpose(1, 2).reshape(B * t, R, C)
        s = s + self.drop(self.spatial(self.norm_s(s)))
        x = s.reshape(B, t, R, C).transpose(1, 2).reshape(B * R, t, C)
        x = x + self.drop(self.temporal(self.norm_t(x)))
        x = x + self.drop(self.mlp(self.norm_f(x)))
        return x.reshape(B, R, t, C)


@faster_version_of(SelfAttention)
class FastSelfAttention(SelfAttention):
    """The rotation is applied in place to the packed projection's q and k parts (one complex product, no copies
    of permuted views); the same products as apply_rotary, so the same values."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if not fast_path() or x.dtype != torch.float32:
            return super().forward(x)
        N, L, C = x.shape
        qkv = self.qkv(x)                                                             # (N, L, 3C), new tensor
        if self.rotary:
            pairs = torch.view_as_complex(qkv.view(N, L, 3 * C // 2, 2))
            pairs[..., :C].mul_(rotary_freqs_qk(L, self.heads, C // self.heads, x.device))
        q, k, v = qkv.view(N, L, 3, self.heads, C // self.heads).permute(2, 0, 3, 1, 4)   # (N, h, L, hd)
        y = F.scaled_dot_product_attention(q, k, v)
        return self.out(y.transpose(1, 2).reshape(N, L, C))


@faster_version_of(CrossBlock)
class FastCrossBlock(CrossBlock):
    """The cross-attention's query and output projections folded into the speech side once per window (`kv`):
    per head h, scores = (LN(x) Wq_h^T + bq_h) K_h^T / sqrt(hd) = LN(x) G_h^T + c_h with G_h = K_h Wq_h / sqrt(hd),
    c_h = K_h bq_h / sqrt(hd); out = sum_h P_h V_h Wo_h^T + bo = P U + bo with U_h = V_h Wo_h^T. A step then runs
    two batched products and one softmax instead of the projections, head reshapes and the attention call."""

    def kv(self, cond: torch.Tensor) -> tuple[torch.Tensor, ...]:
        if not fast_path():
            return super().kv(cond)
        a = self.attn
        k, v = a.project_kv(self.norm_c(cond))                                      # (N, h, S, hd)
        N, H, S, hd = k.shape
        C = H * hd
        wq = a.q.weight.reshape(H, hd, C)
        g = torch.matmul(k, wq).mul_(hd ** -0.5).reshape(N, H * S, C)              # G, heads stacked
        c = torch.matmul(k, a.q.bias.reshape(H, hd, 1)).mul_(hd ** -0.5).reshape(N, 1, H * S)
        u = torch.matmul(v, a.out.weight.reshape(C, H, hd).permute(1, 2, 0)).reshape(N, H * S, C)
        return g.transpose(1, 2).contiguous(), c, u                                  # G^T (N, C, H*S)

    def forward(self, x: torch.Tensor, kv) -> torch.Tensor:
        if len(kv) != 3:                                                             # plain K, V
            return super().forward(x, kv)
        gt, c, u = kv
        N, L, _ = x.shape
        p = torch.baddbmm(c, self.norm1(x), gt)                                     # (N, L, H*S) scores
        p = torch.softmax(p.view(N, L, self.attn.heads, -1), -1).view(N, L, -1)
        x = x + torch.baddbmm(self.attn.out.bias, p, u)
        return x + self.mlp(self.norm2(x))
