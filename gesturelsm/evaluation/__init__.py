"""Evaluation and benchmarks: `gesturelsm eval` (paper metrics over methods x steps x CFG on held-out data)
and `gesturelsm bench` (speed / memory on this machine). Both write JSON, markdown tables and, for the
benchmark, a quality-vs-time plot like the paper's Figure 2.
The names below are imported from their modules on first use, so a torch-free module of this package (the sweep's
limits and defaults, sweep_limits.py) loads without torch."""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_HOME = {"EvalClip": "clips", "heldout_clips": "clips", "EvalPlanItem": "evaluate", "evaluate": "evaluate",
         "plan_grid": "evaluate"}

if TYPE_CHECKING:
    from .clips import EvalClip, heldout_clips
    from .evaluate import EvalPlanItem, evaluate, plan_grid


def __getattr__(name: str) -> Any:
    if name not in _HOME:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_HOME[name]}", __name__), name)
    globals()[name] = value
    return value


__all__ = ["EvalClip", "heldout_clips", "EvalPlanItem", "evaluate", "plan_grid"]
