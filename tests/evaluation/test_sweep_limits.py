"""The sweep's limits and defaults load without torch (evaluation/sweep_limits.py) and name exactly the statistics
a sweep measures."""
from __future__ import annotations

from gesturelsm.evaluation.motion_stats import SEED_SPREAD, STATISTICS
from gesturelsm.evaluation.sweep_limits import PLOT_METRICS


def test_the_sweep_plot_metrics_are_the_statistics():
    assert PLOT_METRICS == tuple(s.key for s in (*STATISTICS, SEED_SPREAD))
