"""The reference denoiser (GestureDenoiser at fe124e0), with its quirks kept because the weights learned them.

Quirks (all deliberate here, see docs/AUTHORS-CODE.md):
- rotary position encoding is applied to the *token features* (values too), once over frames per region
  before the cross-attention, and again per head inside each spatial-temporal attention;
- the (B, 3, 32, C) tokens are reshaped with a raw view to (B, 32, 3C) for cross-attention, so one
  "frame token" mixes three consecutive frames of one region (a bug of their code that the weights learned);
- spatial-temporal blocks run temporal attention, then spatial attention, each with its own residual
  around the *rotated* input, inside the block's residual (x + [rope(h) + attn(rope(h))]);
- the time embedding adds the step-size embedding (through a bias-free linear) *before* its MLP.
Ours is faster than the reference code for the same function (benchmarks/reference_speed.py): loaded for inference,
its linear layers run through oneDNN (kernels.accelerate); the hidden layers' GELU is declared with its product
(kernels.LinearGELU) so it fuses into it; the speech keys/values of the cross-attention are computed once per clip, with
the query and output projections folded into them when the sampler evaluates more than once (`CrossBlock.context`); the
null condition's are kept; rotary tables are cached; attention is fused.
"""
from __future__ import annotations

import math

import torch
import torch.nn as nn
import torch.nn.functional as F

from ..kernels import LinearGELU, WeightsCache, linear
from .config import GeneratorConfig


def timestep_embedding(t: torch.Tensor, dim: int) -> torch.Tensor:
    """(B,) float -> (B, dim) [cos, sin] with frequencies 10000**(-i/(dim/2)); t is not rescaled."""
    half = dim // 2
    freqs = torch.exp(-math.log(10000.0) * torch.arange(half, dtype=torch.float32, device=t.device) / half)
    arg = t[:, None].float() * freqs[None]
    return torch.cat([torch.cos(arg), torch.sin(arg)], dim=-1)


def rope_inv_freq(dim: int) -> torch.Tensor:
    """(dim/2,) rotary frequencies 10000**(-2i/dim): the `inv_freq` buffers of the reference's rotary modules,
    which the port computes instead of loading (reference/convert.py checks a file's buffers against them)."""
    return 1.0 / (10000 ** (torch.arange(0, dim, 2, dtype=torch.float32) / dim))


_ROPE_CACHE: dict[tuple[int, int, str], tuple[torch.Tensor, torch.Tensor]] = {}


def rope_tables(n: int, dim: int, device: torch.device) -> tuple[torch.Tensor, torch.Tensor]:
    """cos, sin (n, dim) for positions 0..n-1; frequencies 10000**(-2i/dim), duplicated over both halves."""
    key = (n, dim, str(device))
    if key not in _ROPE_CACHE:
        inv = rope_inv_freq(dim)
        f = torch.einsum("i,j->ij", torch.arange(n, dtype=torch.float32), inv)
        f = torch.cat([f, f], -1).to(device)
        _ROPE_CACHE[key] = (f.cos(), f.sin())
    return _ROPE_CACHE[key]


def rope(x: torch.Tensor, cos: torch.Tensor, sin: torch.Tensor) -> torch.Tensor:
    """Rotate feature pairs (i, i + D/2) of x (..., n, D) by position angles."""
    h = x.shape[-1] // 2
    rot = torch.cat([-x[..., h:], x[..., :h]], dim=-1)
    return x * cos + rot * sin


class CrossBlock(nn.Module):
    """Pre-LN cross-attention (no qkv bias) + GELU MLP, at width 3C over 32 frame-packed tokens.

    The speech side is fixed for a clip, so the query and output projections are folded into it once per clip
    (`context`): per head h, scores = LN(x) Wq_h^T K_h^T / sqrt(hd) = LN(x) G_h^T with G_h = K_h Wq_h / sqrt(hd),
    and proj(attention) = sum_h P_h V_h Wp_h^T + bp = P U + bp with U_h = V_h Wp_h^T. A step then costs
    2 N D (H M) multiply-adds instead of 2 N D^2 (+ attention): 6.3M against 39M per sample at paper size
    (D 768, H 4, M = N = 32). Same function; fp32 differs from the reference only by summation order (< 1e-5).
    """

    def __init__(self, dim: int, heads: int, hidden: int):
        super().__init__()
        self.heads = heads
        self.norm1, self.norm2 = nn.LayerNorm(dim), nn.LayerNorm(dim)
        self.q = nn.Linear(dim, dim, bias=False)
        self.kv = nn.Linear(dim, 2 * dim, bias=False)
        self.proj = nn.Linear(dim, dim)
        self.fc1, self.fc2 = LinearGELU(dim, hidden), nn.Linear(hidden, dim)

    def context(self, ctx: torch.Tensor, fold: bool = True) -> tuple[torch.Tensor, torch.Tensor]:
        """Speech tokens (B, M, D) -> with `fold`: G (B, H*M, D) scaled score keys and U (B, H*M, D) projected
        values; without: K, V (B, H, M, hd), the plain keys and values (cheaper for a single evaluation)."""
        B, M, D = ctx.shape
        H, hd = self.heads, D // self.heads
        if not fold:
            k, v = self.kv(ctx).reshape(B, M, 2, H, hd).permute(2, 0, 3, 1, 4)        # (B, H, M, hd) each
            return k, v
        k, v = self.kv(ctx).reshape(B * M, 2, H, hd).permute(1, 2, 0, 3)           # (H, B*M, hd) each
        g = torch.bmm(k, self.q.weight.reshape(H, hd, D)).mul_(hd ** -0.5)                # (H, B*M, D)
        u = torch.bmm(v, self.proj.weight.reshape(D, H, hd).permute(1, 2, 0))            # (H, B*M, D)
        return tuple(a.reshape(H, B, M, D).transpose(0, 1).reshape(B, H * M, D) for a in (g, u))

    def forward(self, x: torch.Tensor, kv: tuple[torch.Tensor, torch.Tensor]) -> torch.Tensor:
        B, N, D = x.shape
        if kv[0].dim() == 4:                                                             # plain K, V
            q = self.q(self.norm1(x)).reshape(B, N, self.heads, -1).transpose(1, 2)
            a = F.scaled_dot_product_attention(q, kv[0], kv[1]).transpose(1, 2).reshape(B, N, D)
            x = x + self.proj(a)
        else:                                                                            # folded G, U
            s = torch.bmm(self.norm1(x), kv[0].transpose(1, 2))                          # (B, N, H*M)
            p = torch.softmax(s.reshape(B, N, self.heads, -1), -1).reshape(B, N, -1)
            x = x + torch.baddbmm(self.proj.bias, p, kv[1])
        return x + self.fc2(self.fc1(self.norm2(x)))


class SelfAttention(nn.Module):
    """Multi-head self-attention with packed in-projection (biases), the layout of torch's MultiheadAttention."""

    def __init__(self, dim: int, heads: int):
        super().__init__()
        self.heads = heads
        self.in_proj_weight = nn.Parameter(torch.empty(3 * dim, dim))
        self.in_proj_bias = nn.Parameter(torch.zeros(3 * dim))
        self.out_proj = nn.Linear(dim, dim)
        nn.init.xavier_uniform_(self.in_proj_weight)

    def forward(self, x: torch.Tensor) -> torch.Tensor:  # (B, n, D)
        B, n, D = x.shape
        qkv = linear(x, self.in_proj_weight, self.in_proj_bias).reshape(B, n, 3, self.heads, -1)
        q, k, v = qkv.permute(2, 0, 3, 1, 4)
        return self.out_proj(F.scaled_dot_product_attention(q, k, v).transpose(1, 2).reshape(B, n, D))


class STBlock(nn.Module):
    """h = LN(x); temporal attention over frames per region, then spatial over regions per frame; + MLP."""

    def __init__(self, dim: int, heads: int, hidden: int):
        super().__init__()
        self.heads = heads
        self.norm_attn, self.norm_ff = nn.LayerNorm(dim), nn.LayerNorm(dim)
        self.temporal, self.spatial = SelfAttention(dim, heads), SelfAttention(dim, heads)
        self.fc1, self.fc2 = LinearGELU(dim, hidden), nn.Linear(hidden, dim)

    def _rope_heads(self, x: torch.Tensor) -> torch.Tensor:  # (B, n, D): per-head rotation over positions n
        B, n, D = x.shape
        cos, sin = rope_tables(n, D // self.heads, x.device)
        return rope(x.reshape(B, n, self.heads, -1).transpose(1, 2), cos, sin).transpose(1, 2).reshape(B, n, D)

    def forward(self, x: torch.Tensor) -> torch.Tensor:  # (B, R, N, D)
        B, R, N, D = x.shape
        h = self._rope_heads(self.norm_attn(x).reshape(B * R, N, D))
        h = h + self.temporal(h)                                              # (B*R, N, D)
        s = self._rope_heads(h.reshape(B, R, N, D).transpose(1, 2).reshape(B * N, R, D))
        s = s + self.spatial(s)                                               # (B*N, R, D)
        x = x + s.reshape(B, N, R, D).transpose(1, 2)
        return x + self.fc2(self.fc1(self.norm_ff(x)))


class ReferenceDenoiser(nn.Module):
    """f(x (B, R*Cin, N), t (B,), d (B,) or None, seed (B, S, R*Cin), speech K/V) -> (B, R*Cin, N)."""

    def __init__(self, cfg: GeneratorConfig):
        super().__init__()
        self.cfg = cfg
        C, R = cfg.latent_dim, cfg.regions
        self.time_in, self.time_out = LinearGELU(C, C), nn.Linear(C, C)
        self.step_proj = nn.Linear(C, C, bias=False)
        self.seed_proj = nn.Linear(cfg.input_dim * R * cfg.seed_frames, C)
        self.token_in = nn.Linear(cfg.input_dim, C)
        self.token_fuse = nn.Linear(2 * C, C)
        self.cross = nn.ModuleList([CrossBlock(R * C, cfg.num_heads, R * C * (cfg.ff_size // C))
                                    for _ in range(cfg.num_cross)])
        self.blocks = nn.ModuleList([STBlock(C, cfg.num_heads, C * (cfg.ff_size // C)) for _ in range(cfg.num_layers)])
        self.token_out = nn.Linear(C, cfg.input_dim)
        self.null_cond = nn.Parameter(torch.zeros(cfg.seq_len, R * C))
        self._cache = WeightsCache()

    def speech_kv(self, speech: torch.Tensor, fold: bool = True) -> list[tuple[torch.Tensor, torch.Tensor]]:
        """Speech features (B, N, R*C) -> every cross block's keys/values (CrossBlock.context); once per clip.
        Folding costs more once and less per evaluation: worth it from two evaluations on."""
        return [blk.context(speech, fold) for blk in self.cross]

    def null_kv(self, fold: bool = True) -> list[tuple[torch.Tensor, torch.Tensor]]:
        """speech_kv of the learned null condition (batch 1), the unconditional half of guidance. It depends on
        weights only, so it is kept (per layout) until one of the weights it reads changes; recomputed every time
        when gradients are being recorded for those weights, so they flow."""
        ws = [self.null_cond] + [w for blk in self.cross for w in (blk.kv.weight, blk.q.weight, blk.proj.weight)]
        if torch.is_grad_enabled() and any(w.requires_grad for w in ws):
            return self.speech_kv(self.null_cond[None], fold)
        with torch.no_grad():
            return self._cache.get(("null", fold), ws, lambda: self.speech_kv(self.null_cond[None], fold))

    def forward(self, x: torch.Tensor, t: torch.Tensor, d: torch.Tensor | None, seed: torch.Tensor,
                kv: list[tuple[torch.Tensor, torch.Tensor]]) -> torch.Tensor:
        cfg, C, R = self.cfg, self.cfg.latent_dim, self.cfg.regions
        B, _, N = x.shape
        emb = timestep_embedding(t, C)
        if d is not None:
            emb = emb + self.step_proj(timestep_embedding(d.expand(B), C))
        emb = self.time_out(self.time_in(emb)) + self.seed_proj(seed.reshape(B, -1))                       # (B, C)
        tok = self.token_in(x.reshape(B, R, cfg.input_dim, N).transpose(2, 3))                     # (B, R, N, C)
        # token_fuse(cat[emb, tok]) with the emb half applied once per row, not once per token
        w = self.token_fuse.weight
        tok = linear(tok, w[:, C:], self.token_fuse.bias) + linear(emb, w[:, :C])[:, None, None]
        cos, sin = rope_tables(N, C, x.device)
        tok = rope(tok, cos, sin).reshape(B, N, R * C)  # raw view: token j packs 3 frames of one region
        for blk, blk_kv in zip(self.cross, kv):
            tok = blk(tok, blk_kv)
        tok = tok.reshape(B, R, N, C)
        for blk in self.blocks:
            tok = blk(tok)
        return self.token_out(tok).transpose(2, 3).reshape(B, R * cfg.input_dim, N)
