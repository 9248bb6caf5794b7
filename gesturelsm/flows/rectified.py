"""Baseline: rectified flow (plain flow matching) on the same backbone.

Uniform t, no step-size input (d = 0 always), target x1 - x0 (loss in velocity or data space, as the shortcut
model); Euler sampling with n steps.
Same convention as every method here: t = 0 noise, t = 1 data.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import torch

from .base import FactsMixin, LossResult, MethodFacts, ModelFn, bcast, drop_mask, euler_sample, flow_loss
from .facts import RECTIFIED_FLOW_FACTS
from .timesteps import sample_t


@dataclass
class RectifiedFlow(FactsMixin):
    facts: ClassVar[MethodFacts] = RECTIFIED_FLOW_FACTS
    time_sampler: str = "uniform"
    loss_space: str = "velocity"           # velocity | data (see base.flow_loss)

    @classmethod
    def for_training(cls, prediction: str = "data", time_sampler: str = "beta") -> "RectifiedFlow":
        return cls(loss_space=prediction)   # uniform t: the baseline as published

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
        return euler_sample(f, noise, steps, cfg_scale, d=0.0)
