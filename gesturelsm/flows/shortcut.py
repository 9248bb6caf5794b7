"""GestureLSM's method: latent shortcut flow matching (Frans et al., "One step diffusion via shortcut
models", applied to gesture latents), trained with Beta(2, 1.2) time sampling.

The network f(x_t, t, d) predicts the average velocity over a step of size d from time t; d = 0 is the
ordinary (instantaneous) flow-matching velocity. One batch mixes two kinds of rows:
- flow-matching rows (d = 0): target x1 - x0, with x_t = t x1 + (1 - t) x0 and t ~ Beta(alpha, beta);
- self-consistency rows: pick d from {1/128, ..., 1/2}; the target for a step of 2d is the average of two
  d-steps of the model itself, computed without gradient:
      v1 = f(x_t, t, d);  v2 = f(x_t + d v1, t + d, d);  target(x_t, t, 2d) = (v1 + v2) / 2.
  t for these rows lies on the grid of 2d (t + 2d <= 1), drawn with the same Beta skew. The smallest d is
  queried as d = 0, its instantaneous limit, which the flow rows train directly.
Deliberate choices where the reference has bugs (docs/AUTHORS-CODE.md): the loss is a plain mean squared error
over all rows (no division by t); condition dropout is the same p = 0.1 on every row, and the consistency
targets use exactly the row's own condition (kept or dropped); targets may come from an EMA teacher.
`loss_space="data"` measures the same errors on the implied clean sample x_t + (1 - t) v (see base.flow_loss),
used with networks that predict x1 (GeneratorConfig.prediction = "data"; velocity from base.velocity_from_data).
Sampling: Euler with n steps, t_k = k / n, d = 1 / n (d = 0 from 128 steps on), CFG when scale != 1.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import torch

from .base import FactsMixin, LossResult, MethodFacts, ModelFn, bcast, drop_mask, euler_sample, flow_loss
from .facts import SHORTCUT_FACTS
from .timesteps import sample_t


@dataclass
class Shortcut(FactsMixin):
    facts: ClassVar[MethodFacts] = SHORTCUT_FACTS
    alpha: float = 2.0
    beta: float = 1.2
    time_sampler: str = "beta"             # beta | uniform | logit_normal (ablation)
    consistency_fraction: float = 0.25     # share of rows trained with the self-consistency target
    max_level: int = 7                     # d levels 1/2 ... 1/2^max_level (1/128)
    loss_space: str = "velocity"           # velocity | data (see base.flow_loss)

    @classmethod
    def for_training(cls, prediction: str = "data", time_sampler: str = "beta") -> "Shortcut":
        return cls(loss_space=prediction, time_sampler=time_sampler)

    @property
    def min_d(self) -> float:
        return 1.0 / 2 ** self.max_level

    def consistency_target(self, teacher: ModelFn, x_t: torch.Tensor, t: torch.Tensor, d: torch.Tensor,
                           drop: torch.Tensor, rows: torch.Tensor | None = None) -> torch.Tensor:
        """Average of two d-steps of the teacher from (x_t, t): the target for one 2d-step. No gradient.
        `rows`: which rows of the teacher's bound batch these are (None: all of them)."""
        kw = {} if rows is None else {"rows": rows}
        with torch.no_grad():
            dq = torch.where(d <= self.min_d + 1e-12, torch.zeros_like(d), d)  # smallest level = flow limit
            v1 = teacher(x_t, t, dq, drop, **kw)
            x_mid = x_t + bcast(d, x_t) * v1
            v2 = teacher(x_mid, t + d, dq, drop, **kw)
            return (v1 + v2) / 2

    def loss(self, f: ModelFn, x1: torch.Tensor, cond_drop_p: float = 0.1,
             generator: torch.Generator | None = None, teacher: ModelFn | None = None) -> LossResult:
        B, dev = x1.shape[0], x1.device
        n_sc = int(round(B * self.consistency_fraction)) if B > 1 else 0
        x0 = torch.randn(x1.shape, generator=generator, device=dev)
        t = sample_t(B, self.time_sampler, self.alpha, self.beta, dev, generator)
        d = torch.zeros(B, device=dev)
        drop = drop_mask(B, cond_drop_p, dev, generator)
        if n_sc:
            level = torch.randint(1, self.max_level + 1, (n_sc,), generator=generator, device=dev)
            d_sc = 0.5 ** level.float()                                  # half-step size d
            grid = torch.round(1.0 / (2 * d_sc))                          # number of 2d-steps in [0, 1]
            k = torch.floor(t[:n_sc] * grid).clamp(max=grid - 1)         # keep the Beta skew on the grid
            t[:n_sc] = k * 2 * d_sc
            d[:n_sc] = 2 * d_sc                                           # the network is asked for a 2d step
        x_t = bcast(t, x1) * x1 + (1 - bcast(t, x1)) * x0
        target = x1 - x0
        if n_sc:
            target = target.clone()
            target[:n_sc] = self.consistency_target(teacher or f, x_t[:n_sc], t[:n_sc], d[:n_sc] / 2, drop[:n_sc],
                                                    rows=torch.arange(n_sc, device=dev))
        pred = f(x_t, t, d, drop)
        per_row = flow_loss(pred, target, t, self.loss_space)
        loss = per_row.mean()
        logs = {"flow": per_row[n_sc:].mean().item()}
        if n_sc:
            logs["consistency"] = per_row[:n_sc].mean().item()
        return LossResult(loss, logs)

    def sample(self, f: ModelFn, noise: torch.Tensor, steps: int, cfg_scale: float = 1.0) -> torch.Tensor:
        return euler_sample(f, noise, steps, cfg_scale, d=0.0 if steps >= 2 ** self.max_level else 1.0 / steps)
