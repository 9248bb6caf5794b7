"""Samplers of the released configs, each computing what the reference's forward() computes for one window.

- shortcut (GestureLSM): Euler over t_k = linspace(1e-8, 1 - 1e-8, n + 1), step-size input d = 1/n,
  x += (t_{k+1} - t_k) v; t = 0 noise -> t = 1 data.
- meanflow: t = 1 noise -> t = 0 data; one step: x - u(x, t=1, r=0); n steps over linspace(1 - 1e-8, 0, n + 1)
  with the second time input r = t_{k+1}: x -= (t_k - r) u.
- diffusion: DDIM (eta 0) on the 1000-step squared-cosine schedule, x0 prediction, 'leading' spacing
  (steps 950, 900, ..., 0 for 20), final alpha 1; the first latent is sqrt(1 - abar_950) * noise.
Guidance whenever scale > 1: u + s (c - u) with the learned null condition, both halves in one batch.

Holding known latents (edits): the shortcut and diffusion samplers take `hold` = (known, mask) like the noise, and
before every network call set the known entries to the known latents noised to the call's time with the sampler's
own noise (shortcut: t known + (1 - t) noise; diffusion: sqrt(abar_k) known + sqrt(1 - abar_k) noise), so the rest
is sampled in their context; the result has them exactly (mixed in, where the mask is a float weight: flows/base.py
`hold`). MeanFlow cannot: its one step sees the known latents only as pure noise.
"""
from __future__ import annotations

import math
from typing import Callable

import torch

from ..flows.base import hold as held
from .denoiser import ReferenceDenoiser

KV = list[tuple[torch.Tensor, torch.Tensor]]


def guided_kv(model: ReferenceDenoiser, speech: torch.Tensor, scale: float, steps: int = 2) -> KV:
    """Keys/values for the conditional batch, with the null condition's (kept by the model) stacked after it
    when scale > 1; folded (CrossBlock.context) when the sampler evaluates the model more than once."""
    fold = steps > 1
    kv = model.speech_kv(speech, fold)
    if scale <= 1.0:
        return kv
    B = speech.shape[0]
    return [tuple(torch.cat([c, n.expand(B, *n.shape[1:])]) for c, n in zip(ckv, nkv))
            for ckv, nkv in zip(kv, model.null_kv(fold))]


def _velocity(model: ReferenceDenoiser, kv: KV, seed: torch.Tensor, scale: float) -> Callable:
    def f(x: torch.Tensor, t: torch.Tensor, d: torch.Tensor | None) -> torch.Tensor:
        B = x.shape[0]
        if scale <= 1.0:
            return model(x, t.expand(B), d, seed, kv)
        out = model(torch.cat([x, x]), t.expand(2 * B), d, torch.cat([seed, seed]), kv)
        c, u = out.chunk(2)
        return u + scale * (c - u)
    return f


def shortcut(model: ReferenceDenoiser, noise: torch.Tensor, speech: torch.Tensor, seed: torch.Tensor,
             steps: int, scale: float, hold: tuple[torch.Tensor, torch.Tensor] | None = None) -> torch.Tensor:
    f = _velocity(model, guided_kv(model, speech, scale, steps), seed, scale)
    ts = torch.linspace(1e-8, 1 - 1e-8, steps + 1)
    d = torch.tensor([1.0 / steps])
    x = noise
    for k in range(steps):
        if hold is not None:
            x = held(x, ts[k] * hold[0] + (1 - ts[k]) * noise, hold[1])
        x = x + (ts[k + 1] - ts[k]) * f(x, ts[k:k + 1], d)
    return x if hold is None else held(x, hold[0], hold[1])


def meanflow(model: ReferenceDenoiser, noise: torch.Tensor, speech: torch.Tensor, seed: torch.Tensor,
             steps: int, scale: float) -> torch.Tensor:
    f = _velocity(model, guided_kv(model, speech, scale, steps), seed, scale)
    if steps == 1:
        return noise - f(noise, torch.ones(1), torch.zeros(1))
    ts = torch.linspace(1 - 1e-8, 0, steps + 1)
    x = noise
    for k in range(steps):
        x = x - (ts[k:k + 1] - ts[k + 1:k + 2]) * f(x, ts[k:k + 1], ts[k + 1:k + 2])
    return x


def cosine_alphas_cumprod(n: int = 1000, max_beta: float = 0.999) -> torch.Tensor:
    """(n,) float32 cumulative products of 1 - beta_i for the squared-cosine schedule (as diffusers builds it)."""
    f = lambda u: math.cos((u + 0.008) / 1.008 * math.pi / 2) ** 2  # noqa: E731
    betas = torch.tensor([min(1 - f((i + 1) / n) / f(i / n), max_beta) for i in range(n)], dtype=torch.float32)
    return torch.cumprod(1.0 - betas, dim=0)


def diffusion(model: ReferenceDenoiser, noise: torch.Tensor, speech: torch.Tensor, seed: torch.Tensor,
              steps: int, scale: float, train_steps: int = 1000,
              hold: tuple[torch.Tensor, torch.Tensor] | None = None) -> torch.Tensor:
    f = _velocity(model, guided_kv(model, speech, scale, steps), seed, scale)
    ac = cosine_alphas_cumprod(train_steps)
    ratio = train_steps // steps
    ks = [k * ratio for k in reversed(range(steps))]
    x = (1 - ac[ks[0]]) ** 0.5 * noise
    for k in ks:
        if hold is not None:
            x = held(x, ac[k] ** 0.5 * hold[0] + (1 - ac[k]) ** 0.5 * noise, hold[1])
        x0 = f(x, torch.tensor([float(k)]), None)
        a_t = ac[k]
        a_prev = ac[k - ratio] if k - ratio >= 0 else torch.tensor(1.0)
        eps = (x - a_t ** 0.5 * x0) / (1 - a_t) ** 0.5
        x = a_prev ** 0.5 * x0 + (1 - a_prev) ** 0.5 * eps
    return x if hold is None else held(x, hold[0], hold[1])


SAMPLERS = {"shortcut": shortcut, "meanflow": meanflow, "diffusion": diffusion}
HOLDS_KNOWN = ("shortcut", "diffusion")         # the samplers that take `hold`
