"""Evaluation and benchmarks: `gesturelsm eval` (paper metrics over methods x steps x CFG on held-out data)
and `gesturelsm bench` (speed / memory on this machine). Both write JSON, markdown tables and, for the
benchmark, a quality-vs-time plot like the paper's Figure 2.
The names below are imported from their modules on first use, so a torch-free module of this package (the sweep's
limits and defaults, sweep_limits.py) loads without torch."""
from __future__ import annotations

from typing import TYPE_CHECKING

from ..lazy import lazy_names

_HOME = {"EvalClip": "clips", "heldout_clips": "clips", "EvalPlanItem": "evaluate", "plan_grid": "evaluate"}

if TYPE_CHECKING:
    from .clips import EvalClip, heldout_clips
    from .evaluate import EvalPlanItem, plan_grid


__getattr__ = lazy_names(__name__, _HOME)


__all__ = ["EvalClip", "heldout_clips", "EvalPlanItem", "plan_grid"]
