"""A module recorded once for fixed input shapes (torch.jit.trace), taken where measured faster than running it.

A trace replays the same ATen calls without the Python interpreter and the module calls between them, a sizeable
share of a step for a small model; whether that share is worth anything depends on the CPU and the thread count,
so the `trace` path is measured like the kernels (choice.py), on the module's real inputs. The recording reads the
module's parameter tensors in place; its caller drops it when a weight changes (ops.WeightsCache).
"""
from __future__ import annotations

import warnings
from typing import Callable

import torch
import torch.nn as nn

from .choice import Switch, decide


def traced_or_eager(module: nn.Module, args: tuple[torch.Tensor, ...], name: str) -> Callable[..., torch.Tensor]:
    """`module` itself or its trace for inputs of these shapes, whichever was measured faster (`name` and the
    shapes key the choice). Made once per shape by the caller and kept; a module the tracer cannot record runs as
    it is. A trace chosen by another process (read from the cache) is recorded only once this process has called
    it often enough to pay for the recording, or at once when the work ahead will (choice.Switch); until then the
    module runs as it is."""
    made: list[Callable[..., torch.Tensor]] = []

    def record() -> Callable[..., torch.Tensor]:
        if not made:
            made.append(_trace(module, args))
        return made[0]

    key = (name, *(tuple(a.shape) for a in args))
    got = decide("trace", key, lambda: ((lambda: module(*args)), (lambda: record()(*args))))
    if got is None or not got.taken:
        return module
    if got.break_even() == 0:
        return record()
    switch = Switch(got)

    def run(*a: torch.Tensor) -> torch.Tensor:                  # read from the cache: recorded once it pays off
        return record()(*a) if switch.take() else module(*a)
    return run


def _trace(module: nn.Module, args: tuple[torch.Tensor, ...]) -> Callable[..., torch.Tensor]:
    """torch.jit.trace of `module` on `args` (warm-up call first, so the choices inside it are made eagerly and
    recorded as made); `module` itself if the tracer cannot record it."""
    with torch.no_grad():
        module(*args)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return torch.jit.trace(module, args, check_trace=False)
        except RuntimeError:
            return module
