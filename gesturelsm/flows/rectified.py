"""Baseline: rectified flow (plain flow matching) on the same backbone.

Uniform t, no step-size input (d = 0 always), target x1 - x0 (loss in velocity or data space, as the shortcut
model); Euler sampling with n steps.
Same convention as every method here: t = 0 noise, t = 1 data.
"""
from __future__ import annotations

from dataclasses import dataclass

import torch

from .base import LossResult, ModelFn, bcast, drop_mask, flow_loss, guided
from .timesteps import sample_t


@dataclass
class RectifiedFlow:
    time_sampler: str = "uniform"
    loss_space: str = "velocity"           # velocity | data (see base.flow_loss)
    name: str = "rectified_flow"
    uses_step_size: bool = False

    def loss(self, f: ModelFn, x1: torch.Tensor, cond_drop_p: float = 0.1,
             generator: torch.Generator | None = None, teacher: ModelFn | None = None) -> LossResult:
        B, dev = x1.shape[0], x1.device
        x0 = torch.randn(x1.shape, generator=generator, device=dev)
        t = sample_t(B, self.time_sampler, device=dev, generator=generator)
        x_t = bcast(t, x1) * x1 + (1 - bcast(t, x1)) * x0
        pred = f(x_t, t, torch.zeros(B, device=dev), drop_mask(B, cond_drop_p, dev, generator))
        loss = flow_loss(pred, x1 - x0, t, self.loss_space).mean()
        return LossResult(loss, {"flow": loss.item()})

    def sample(self, f: ModelFn, noise: torch.Tensor, steps: int, cfg_scale: float = 1.0) -> torch.Tensor:
        if not 1 <= steps <= 1024:
            raise ValueError(f"steps must be between 1 and 1024 (got {steps})")
        B, x = noise.shape[0], noise
        d = torch.zeros(B, device=x.device)
        for k in range(steps):
            t = torch.full((B,), k / steps, device=x.device)
            x = x + (1.0 / steps) * guided(f, x, t, d, cfg_scale)
        return x
