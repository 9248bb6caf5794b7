"""The interface every generative method implements, and classifier-free guidance.

Convention (all methods): **t = 0 is noise, t = 1 is data**; x_t = t * x1 + (1 - t) * x0 for the flows.
A *model function* is `f(x, t, d, drop) -> prediction`:
    x: (B, ...) current state, t: (B,) time in [0, 1], d: (B,) step size (0 = instantaneous),
    drop: (B,) bool, True where the speech condition is replaced by the learned null condition.
It may be called with a batch that is a multiple of the bound condition's batch (CFG stacks the
conditional and unconditional halves into one call), or, with the keyword `rows` (a (b,) index tensor),
on a subset of the rows of the batch it was bound to (the shortcut targets need only some rows).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, ClassVar, Protocol

import torch

from .facts import MethodFacts

ModelFn = Callable[[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor], torch.Tensor]


@dataclass
class LossResult:
    loss: torch.Tensor               # scalar to minimise
    logs: dict[str, float]           # parts of the loss for progress bars


class Method(Protocol):
    facts: ClassVar[MethodFacts]

    @property
    def name(self) -> str: ...

    @property
    def uses_step_size(self) -> bool: ...

    @classmethod
    def for_training(cls, prediction: str = "data", time_sampler: str = "beta") -> "Method":
        """The method as `gesturelsm train` configures it (options a method does not have are ignored)."""

    def loss(self, f: ModelFn, x1: torch.Tensor, cond_drop_p: float = 0.1,
             generator: torch.Generator | None = None, teacher: ModelFn | None = None) -> LossResult: ...

    def sample(self, f: ModelFn, noise: torch.Tensor, steps: int, cfg_scale: float = 1.0) -> torch.Tensor: ...

    def noised(self, x1: torch.Tensor, x0: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        """The state the model sees at time t (B,) for data x1 and noise x0 (the method's forward process)."""


class FactsMixin:
    """`name` and `uses_step_size` read from the class's `facts`; the flows' straight path as `noised`."""
    facts: ClassVar[MethodFacts]

    def noised(self, x1: torch.Tensor, x0: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        """x_t = t x1 + (1 - t) x0 (the flows' path; DDIM overrides it with its noise schedule)."""
        return bcast(t, x1) * x1 + (1 - bcast(t, x1)) * x0

    @property
    def name(self) -> str:
        return self.facts.key

    @property
    def uses_step_size(self) -> bool:
        return self.facts.uses_step_size


def euler_sample(f: ModelFn, noise: torch.Tensor, steps: int, cfg_scale: float, d: float) -> torch.Tensor:
    """The flows' sampler: n Euler steps t_k = k / n from noise (t = 0) to data (t = 1), step-size input `d`
    on every call (0 = instantaneous velocity), classifier-free guidance when cfg_scale != 1."""
    B, x = noise.shape[0], noise
    dd = torch.full((B,), d, device=x.device)
    for k in range(steps):
        t = torch.full((B,), k / steps, device=x.device)
        x = x + (1.0 / steps) * guided(f, x, t, dd, cfg_scale)
    return x


def inpainting(f: ModelFn, method: "Method", known: torch.Tensor, mask: torch.Tensor, noise: torch.Tensor) -> ModelFn:
    """f for sampling with part of x known (replacement inpainting): before every call the known entries of x are
    set to `known` noised to the call's time with the sampler's own initial `noise`, so the prediction of the
    rest is conditioned on them (any method, any step count). known, noise: (B, ...) like x; mask: broadcastable,
    bool (True where known) or float weights in [0, 1] (soft: x becomes mask * noised known + (1 - mask) * x).
    CFG-stacked batches (a multiple of B) are handled."""
    def g(x: torch.Tensor, t: torch.Tensor, d: torch.Tensor, drop: torch.Tensor, **kw) -> torch.Tensor:
        r = x.shape[0] // known.shape[0]
        rep = lambda a: a.repeat(r, *[1] * (x.ndim - 1))  # noqa: E731
        return f(hold(x, method.noised(rep(known), rep(noise), t), rep(mask) if mask.shape[0] > 1 else mask), t, d,
                 drop, **kw)
    return g


def hold(x: torch.Tensor, known: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """x with `known` where `mask`: bool (exactly there) or float weights in [0, 1] (mixed by them)."""
    if mask.dtype == torch.bool:
        return torch.where(mask, known, x)
    return mask * known + (1 - mask) * x


def guided(f: ModelFn, x: torch.Tensor, t: torch.Tensor, d: torch.Tensor, scale: float) -> torch.Tensor:
    """Classifier-free guidance: u + s (c - u), conditional and unconditional in one batched call.

    scale == 1 is exactly the conditional prediction (one pass, no null-condition call).
    """
    B = x.shape[0]
    no = torch.zeros(B, dtype=torch.bool, device=x.device)
    if scale == 1.0:
        return f(x, t, d, no)
    out = f(torch.cat([x, x]), torch.cat([t, t]), torch.cat([d, d]), torch.cat([no, ~no]))
    cond, uncond = out[:B], out[B:]
    return uncond + scale * (cond - uncond)


def drop_mask(B: int, p: float, device, generator: torch.Generator | None = None) -> torch.Tensor:
    """(B,) bool: True with probability p (the condition is dropped for CFG training)."""
    return torch.rand(B, generator=generator, device=device) < p


def velocity_from_data(x1_hat: torch.Tensor, x: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
    """Data (x1) parametrisation of a flow's velocity: v = (x1_hat - x_t) / (1 - t).

    With it the noise in x_t is removed exactly by construction (one step from t = 0 lands on x1_hat), instead
    of having to be learned as a -x_t term of the network's output, which small or briefly trained networks
    learn slowly and leave as temporally white jitter. Samplers never query t = 1; the clamp only guards it.
    """
    return (x1_hat - x) / bcast((1 - t).clamp_min(1e-4), x)


def flow_loss(pred: torch.Tensor, target: torch.Tensor, t: torch.Tensor, space: str) -> torch.Tensor:
    """(B,) per-row MSE of a velocity `pred` against `target` at times t.

    space "velocity": ||v - v*||^2 (the paper's loss); "data": ||x1_hat - x1*||^2 = (1 - t)^2 ||v - v*||^2,
    the same error measured on the implied clean sample, which keeps t near 1 from dominating.
    """
    err = (pred - target).pow(2).flatten(1).mean(1)
    if space == "data":
        return err * (1 - t).pow(2)
    if space != "velocity":
        raise ValueError(f"unknown loss space {space!r}")
    return err


def bcast(v: torch.Tensor, like: torch.Tensor) -> torch.Tensor:
    """(B,) -> (B, 1, 1, ...) to broadcast against `like`."""
    return v.reshape(-1, *([1] * (like.ndim - 1)))
