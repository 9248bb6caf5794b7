"""Evaluation and benchmarks: `gesturelsm eval` (paper metrics over methods x steps x CFG on held-out data)
and `gesturelsm bench` (speed / memory on this machine). Both write JSON, markdown tables and, for the
benchmark, a quality-vs-time plot like the paper's Figure 2."""
from .clips import EvalClip, heldout_clips
from .evaluate import EvalPlanItem, evaluate, plan_grid

__all__ = ["EvalClip", "heldout_clips", "EvalPlanItem", "evaluate", "plan_grid"]
