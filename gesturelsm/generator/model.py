"""The GestureLSM network: speech encoder + spatial-temporal transformer denoiser over region latents.

Shapes (B batch, R regions, t = 32 latent frames per 128-frame window, D latent dim, s seed latents):
    x      (B, R, t, D)   noisy latents (or, for DDIM, noised latents); output has the same shape
    t, d   (B,)           flow time (0 noise -> 1 data) and step size (0 = instantaneous)
    cond   (B, t, C)      fused speech features, one per latent frame
    seed   (B, R, s, D)   the previous window's last latents (or the neutral seed)
    drop   (B,)           True: use the learned null condition instead of `cond` (classifier-free guidance)
"""
from __future__ import annotations

from pathlib import Path
from typing import Any, Iterable, NamedTuple, cast

import torch
import torch.nn as nn
import torch.nn.functional as F

from ..checkpoint import config_from_dict, load_checkpoint, save_checkpoint
from ..features.audio import AudioEncoder
from ..flows import method_facts
from ..kernels import WeightsCache, accelerate, fast_path, faster_version_of, linear, traced_or_eager
from ..flows.base import velocity_from_data
from .config import GeneratorConfig
from .layers import CrossBlock, STBlock, sinusoidal

KIND = "gesturelsm.generator"


class SpeechEncoder(nn.Module):
    """audio channels (B, 2, N) + per-frame word vectors (B, T, 384) -> (B, T/4, cond_dim)."""

    def __init__(self, c: GeneratorConfig):
        super().__init__()
        self.audio = AudioEncoder(c.audio_channels, pool=c.audio_pool)
        self.text_proj = nn.Linear(c.text_in, c.text_dim)
        self.pad = nn.Parameter(torch.zeros(c.text_dim))       # silence between words
        self.no_text = nn.Parameter(torch.zeros(c.text_dim))   # no transcript at all (audio-only mode)
        self.fuse = nn.Linear(self.audio.out_dim + c.text_dim, c.cond_dim)
        self.pos = nn.Parameter(torch.zeros(c.window_latents, c.cond_dim))
        nn.init.normal_(self.pad, std=0.02)
        nn.init.normal_(self.no_text, std=0.02)
        nn.init.normal_(self.pos, std=0.02)

    def forward(self, audio: torch.Tensor, words: torch.Tensor, has_word: torch.Tensor,
                has_text: torch.Tensor) -> torch.Tensor:
        """audio (B, 2, N); words (B, T, 384); has_word (B, T) bool; has_text (B,) bool."""
        T = words.shape[1]
        a = self.audio(audio, T)                                                  # (B, T, A)
        w = torch.where(has_word[..., None], self.text_proj(words), self.pad)    # (B, T, Tx)
        w = torch.where(has_text[:, None, None], w, self.no_text)
        h = self.fuse(torch.cat([a, w], dim=-1))                                 # (B, T, C)
        h = F.avg_pool1d(h.transpose(1, 2), 4).transpose(1, 2)                   # (B, T/4, C)
        return h + self.pos[: h.shape[1]]


class SpeechContext(NamedTuple):
    """What the denoiser reads of the speech condition, computed once per window (not at every step)."""
    kv: list[tuple[torch.Tensor, ...]]   # per cross block: K, V (B, heads, t, head_dim), or FastCrossBlock's fold
    frames: torch.Tensor | None                   # (B, t, dim) frame-aligned speech term (config.speech_add)

    def rows(self, idx) -> "SpeechContext":
        """The same context for a subset of rows (an index tensor or a slice)."""
        return SpeechContext([tuple(a[idx] for a in kv) for kv in self.kv],
                             None if self.frames is None else self.frames[idx])

    def select(self, drop: torch.Tensor, null: "SpeechContext") -> "SpeechContext":
        """Row-wise: `null` where drop (B,), else self (null may have batch 1 and broadcasts)."""
        kv = [tuple(torch.where(drop.reshape(-1, *[1] * (c.dim() - 1)), u, c) for c, u in zip(kv_c, kv_u))
              for kv_c, kv_u in zip(self.kv, null.kv)]
        frames = None if self.frames is None else torch.where(drop.reshape(-1, 1, 1), cast(torch.Tensor, null.frames),
                                                              self.frames)
        return SpeechContext(kv, frames)


class Denoiser(nn.Module):
    def __init__(self, c: GeneratorConfig):
        super().__init__()
        self.c = c
        R, D, C = c.num_regions, c.latent_dim, c.dim
        self.in_proj = nn.Linear(D, C)
        self.region_emb = nn.Parameter(torch.randn(R, C) * 0.02)
        self.frame_emb = nn.Parameter(torch.randn(c.window_latents, C) * 0.02)
        self.t_embed = nn.Linear(C, C)
        self.d_embed = nn.Linear(C, C)
        self.emb_mlp = nn.Sequential(nn.Linear(C, C), nn.GELU(), nn.Linear(C, C))
        self.seed_proj = nn.Linear(R * c.seed_latents * D, C)
        self.merge = nn.Linear(2 * C, C)
        self.cross = nn.ModuleList(CrossBlock(C, c.cond_dim, c.heads, c.ffn,
                                              c.drop_path) for _ in range(c.cross_layers))
        self.st = nn.ModuleList(STBlock(C, c.heads, c.ffn, c.drop_path) for _ in range(c.st_layers))
        self.speech_in = nn.Sequential(nn.LayerNorm(c.cond_dim), nn.Linear(c.cond_dim, C)) if c.speech_add else None
        self.out_norm = nn.LayerNorm(C)
        self.out = nn.Linear(C, D)
        nn.init.zeros_(self.d_embed.weight)   # d enters through a zero-initialised layer, as in the authors' code
        nn.init.zeros_(self.d_embed.bias)
        nn.init.zeros_(self.out.weight)       # start as the zero velocity
        nn.init.zeros_(self.out.bias)

    def embed(self, t: torch.Tensor, d: torch.Tensor, seed: torch.Tensor) -> torch.Tensor:
        C = self.c.dim
        e = self.t_embed(sinusoidal(t, C))
        if self.c.uses_step_size:
            e = e + self.d_embed(sinusoidal(d, C))
        return self.emb_mlp(e) + self.seed_proj(seed.flatten(1))       # (B, C)

    def context(self, cond: torch.Tensor) -> SpeechContext:
        """(B, t, cond_dim) speech features -> what forward() reads of them."""
        return SpeechContext([blk.kv(cond) for blk in cast("Iterable[CrossBlock]", self.cross)],
                             self.speech_in(cond) if self.speech_in is not None else None)

    def forward(self, x: torch.Tensor, t: torch.Tensor, d: torch.Tensor, seed: torch.Tensor,
                ctx: SpeechContext) -> torch.Tensor:
        B, R, tt, _ = x.shape
        h = self.in_proj(x) + self.region_emb[None, :, None] + self.frame_emb[None, None, :tt]   # (B, R, t, C)
        e = self.embed(t, d, seed)[:, None, None].expand(-1, R, tt, -1)
        h = self.merge(torch.cat([h, e], dim=-1))
        if ctx.frames is not None:
            h = h + ctx.frames[:, None, :tt]                               # every region of frame i gets speech i
        h = h.reshape(B, R * tt, -1)
        for block, kv_i in zip(self.cross, ctx.kv):
            h = block(h, kv_i)
        h = h.reshape(B, R, tt, -1)
        for block in self.st:
            h = block(h)
        return self.out(self.out_norm(h))                                # (B, R, t, D)


@faster_version_of(Denoiser)
class FastDenoiser(Denoiser):
    """Guidance stacks the same x, t, d and seed twice (conditional, then null half): everything before the first
    cross block is computed once for both; `merge` applies its embedding half once per row, not once per token."""

    def forward(self, x: torch.Tensor, t: torch.Tensor, d: torch.Tensor, seed: torch.Tensor,
                ctx: SpeechContext) -> torch.Tensor:
        if not fast_path() or self.training or x.dtype != torch.float32:
            return super().forward(x, t, d, seed, ctx)
        B, R, tt, _ = x.shape
        n = B // 2
        twice = B % 2 == 0 and all(torch.equal(a[:n], a[n:]) for a in (x, t, d, seed))
        if twice:
            x, t, d, seed = x[:n], t[:n], d[:n], seed[:n]
        C = self.c.dim
        w_h, w_e = self._cache.get("merge", [self.merge.weight], lambda: (self.merge.weight[:, :C].contiguous(),
                                                                          self.merge.weight[:, C:].contiguous()))
        h = self.in_proj(x) + self.region_emb[None, :, None] + self.frame_emb[None, None, :tt]   # (b, R, t, C)
        h = linear(h, w_h) + linear(self.embed(t, d, seed), w_e, self.merge.bias)[:, None, None]
        if twice:
            h = h.repeat(2, 1, 1, 1)
        if ctx.frames is not None:
            h = h + ctx.frames[:, None, :tt]
        kv = [a for kv_i in ctx.kv for a in kv_i]
        key = ("trunk", h.shape, *(a.shape for a in kv))
        trunk = self._cache.get(key, list(self.parameters()),
                                lambda: traced_or_eager(_Trunk(self, len(ctx.kv[0])), (h, *kv), "denoiser trunk"))
        return trunk(h, *kv)

    @property
    def _cache(self) -> WeightsCache:
        return self.__dict__.setdefault("_weights_cache", WeightsCache())


class _Trunk(nn.Module):
    """The denoiser after its input embedding: cross blocks, spatial-temporal blocks, output layer, on (B, R, t, C)
    tokens and the speech context's tensors flattened (what tracing needs: tensors in, tensor out). FastDenoiser
    runs it recorded once per shape where that is measured faster (kernels.traced_or_eager)."""

    def __init__(self, den: Denoiser, per_block: int):
        super().__init__()
        self.cross, self.st, self.out_norm, self.out = den.cross, den.st, den.out_norm, den.out
        self.per_block = per_block

    def forward(self, h: torch.Tensor, *kv: torch.Tensor) -> torch.Tensor:
        B, R, tt, C = h.shape
        h = h.reshape(B, R * tt, C)
        for i, block in enumerate(self.cross):
            h = block(h, kv[i * self.per_block:(i + 1) * self.per_block])
        h = h.reshape(B, R, tt, C)
        for block in self.st:
            h = block(h)
        return self.out(self.out_norm(h))


class GestureGenerator(nn.Module):
    latent_std: torch.Tensor          # buffers: (R,) and (R, s, D)
    neutral_seed: torch.Tensor
    meta: dict[str, Any]              # a loaded checkpoint's metadata besides its config

    def __init__(self, config: GeneratorConfig, method: str = "gesturelsm"):
        super().__init__()
        self.config, self.method = config, method
        self.speech = SpeechEncoder(config)
        self.denoiser = Denoiser(config)
        self.null_cond = nn.Parameter(torch.randn(config.window_latents, config.cond_dim) * 0.02)
        R, s, D = config.num_regions, config.seed_latents, config.latent_dim
        # per-region latent scale (the paper uses a fixed 1/5; we store the measured std of the training
        # latents so every region enters the flow at unit scale) and the neutral seed for a first window
        self.register_buffer("latent_std", torch.ones(R))
        self.register_buffer("neutral_seed", torch.zeros(R, s, D))

    # ---- conditioning ---------------------------------------------------------------------------------
    def context(self, cond: torch.Tensor, drop: torch.Tensor) -> SpeechContext:
        """The denoiser's speech context, with the null condition where `drop` (B,)."""
        null = self.null_cond[None, : cond.shape[1]].expand_as(cond)
        return self.denoiser.context(torch.where(drop[:, None, None], null, cond))

    def contexts(self, cond: torch.Tensor) -> tuple[SpeechContext, SpeechContext]:
        """(conditional, null) contexts for a (B, t, C) condition; the null one has batch 1 (the null condition
        is the same for every row) and broadcasts in `bind`."""
        no = torch.zeros(cond.shape[0], dtype=torch.bool, device=cond.device)
        return self.context(cond, no), self.context(cond[:1], ~no[:1])

    def bind(self, cond: torch.Tensor, seed: torch.Tensor,
             ctx: tuple[SpeechContext, SpeechContext] | None = None):
        """A model function f(x, t, d, drop) for the samplers (see flows/base.py), with the conditional and
        null contexts computed once, not at every step (`ctx`: `contexts(cond)` when the caller already has
        them). Accepts batches that are multiples of cond's batch."""
        B = cond.shape[0]
        ctx_c, ctx_u = ctx if ctx is not None else self.contexts(cond)
        last: list = [None, None]          # (batch, drop) of the last call without `rows`, and its context

        def f(x: torch.Tensor, t: torch.Tensor, d: torch.Tensor, drop: torch.Tensor,
              rows: torch.Tensor | None = None) -> torch.Tensor:
            idx = torch.arange(B, device=x.device) if rows is None else rows
            idx = idx.repeat(x.shape[0] // len(idx))                  # CFG stacks both halves
            if rows is None and last[0] is not None and last[0][0] == x.shape[0] and torch.equal(last[0][1], drop):
                c = last[1]                                           # every sampling step asks for the same rows
            else:
                c = ctx_c.rows(idx).select(drop, ctx_u)
                if rows is None:
                    last[:] = [(x.shape[0], drop.clone()), c]
            return self.output(self.denoiser(x, t, d, seed[idx], c), x, t)

        return f

    def output(self, y: torch.Tensor, x: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        """The denoiser's output as the method expects it: a flow's velocity (from x1 when the network predicts
        data, see GeneratorConfig.prediction), DDIM's clean latents."""
        if self.config.prediction == "data" and method_facts(self.method).samples_with == "velocity":
            return velocity_from_data(y, x, t)
        return y

    def forward(self, x, t, d, cond, seed, drop, speech: tuple | None = None) -> torch.Tensor:
        """Training path (no caching). `speech` = (audio, words, has_word, has_text) computes `cond` inside
        this call, which DistributedDataParallel needs to see every parameter used."""
        if speech is not None:
            cond = self.speech(*speech)
            cond = cond.repeat(x.shape[0] // cond.shape[0], 1, 1)
        y = self.denoiser(x, t, d, seed.repeat(x.shape[0] // seed.shape[0], 1, 1, 1), self.context(cond, drop))
        return self.output(y, x, t)

    # ---- files -----------------------------------------------------------------------------------------
    def save(self, path: str | Path, half: bool = False, meta: dict | None = None) -> Path:
        return save_checkpoint(path, self.state_dict(), KIND, self.config, {"method": self.method, **(meta or {})},
                               half=half)

    @classmethod
    def load(cls, path: str | Path, accelerated: bool = True) -> "GestureGenerator":
        """A saved generator, in eval mode, with the fast kernels and the accelerated blocks swapped in unless
        `accelerated` is False (kernels.accelerate: the same function; training it further takes the default ops)."""
        tensors, meta = load_checkpoint(path, KIND)
        model = cls(config_from_dict(GeneratorConfig, meta["config"]), meta.get("method", "gesturelsm"))
        model.load_state_dict(tensors)
        model.meta = {k: v for k, v in meta.items() if k != "config"}
        return accelerate(model.eval()) if accelerated else model.eval()
