"""Baseline: DDIM diffusion with x0 (clean-data) prediction on the same backbone.

A 1000-step cosine noise schedule (Nichol & Dhariwal): x_k = sqrt(abar_k) x1 + sqrt(1 - abar_k) eps for
diffusion step k = 0 (almost clean) ... 999 (pure noise). The network sees t = 1 - (k + 1) / 1000, so the
project-wide convention holds (t = 0 noise, t = 1 data), and predicts x1. Sampling: N-step DDIM (eta = 0)
over evenly spaced steps from 999 down to 0, guidance applied to the x1 prediction.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import torch

from .base import FactsMixin, LossResult, MethodFacts, ModelFn, bcast, drop_mask, guided
from .facts import DDIM_FACTS, NUM_TRAIN_STEPS


def cosine_alpha_bar(num_steps: int = NUM_TRAIN_STEPS, s: float = 0.008) -> torch.Tensor:
    """(num_steps,) cumulative signal fraction abar_k, k = 0 .. num_steps - 1 (betas clipped at 0.999)."""
    f = lambda u: math.cos((u / num_steps + s) / (1 + s) * math.pi / 2) ** 2  # noqa: E731
    betas = [min(1 - f(k + 1) / f(k), 0.999) for k in range(num_steps)]
    return torch.cumprod(1 - torch.tensor(betas, dtype=torch.float64), 0).float()


def model_time(k: torch.Tensor) -> torch.Tensor:
    return 1.0 - (k.float() + 1) / NUM_TRAIN_STEPS


@dataclass
class DDIM(FactsMixin):
    facts: ClassVar[MethodFacts] = DDIM_FACTS
    alpha_bar: torch.Tensor = field(default_factory=cosine_alpha_bar)

    def loss(self, f: ModelFn, x1: torch.Tensor, cond_drop_p: float = 0.1,
             generator: torch.Generator | None = None, teacher: ModelFn | None = None) -> LossResult:
        B, dev = x1.shape[0], x1.device
        k = torch.randint(0, NUM_TRAIN_STEPS, (B,), generator=generator, device=dev)
        eps = torch.randn(x1.shape, generator=generator, device=dev)
        ab = bcast(self.alpha_bar.to(dev)[k], x1)
        x_k = ab.sqrt() * x1 + (1 - ab).sqrt() * eps
        pred = f(x_k, model_time(k), torch.zeros(B, device=dev), drop_mask(B, cond_drop_p, dev, generator))
        loss = (pred - x1).pow(2).mean()
        return LossResult(loss, {"x0": loss.item()})

    @classmethod
    def for_training(cls, prediction: str = "data", time_sampler: str = "beta") -> "DDIM":
        return cls()                        # always x0 prediction, its own noise schedule

    def noised(self, x1: torch.Tensor, x0: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        """x_k = sqrt(abar_k) x1 + sqrt(1 - abar_k) x0 for the diffusion step k whose model time is t."""
        k = ((1 - t) * NUM_TRAIN_STEPS - 1).round().long().clamp(0, NUM_TRAIN_STEPS - 1)
        ab = bcast(self.alpha_bar.to(x1.device)[k], x1)
        return ab.sqrt() * x1 + (1 - ab).sqrt() * x0

    def sample(self, f: ModelFn, noise: torch.Tensor, steps: int, cfg_scale: float = 1.0) -> torch.Tensor:
        B, x, dev = noise.shape[0], noise, noise.device
        ab = self.alpha_bar.to(dev)
        ks = torch.linspace(NUM_TRAIN_STEPS - 1, 0, steps).round().long().tolist()
        x1_hat = x
        for i, k in enumerate(ks):
            kt = torch.full((B,), k, device=dev, dtype=torch.long)
            x1_hat = guided(f, x, model_time(kt), torch.zeros(B, device=dev), cfg_scale)
            if i == len(ks) - 1:
                break
            eps = (x - ab[k].sqrt() * x1_hat) / (1 - ab[k]).sqrt()
            k_next = ks[i + 1]
            x = ab[k_next].sqrt() * x1_hat + (1 - ab[k_next]).sqrt() * eps
        return x1_hat
