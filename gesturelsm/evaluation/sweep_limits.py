"""What a sweep may hold and what it runs with when nothing is given, without torch: `gesturelsm sweep --help`, the
page's Sweep tab and evaluation/sweep.py read them from here."""
from __future__ import annotations

from dataclasses import dataclass

from ..settings import DEFAULT_CFG


@dataclass(frozen=True)
class SweepLimits:
    max_cells: int = 72                 # (method, steps, CFG) combinations
    max_seeds: int = 4
    max_work: float = 1500.0            # seconds of motion generated in all: cells x seeds x speech seconds

    def describe(self) -> str:
        return (f"at most {self.max_cells} combinations, {self.max_seeds} seeds, and {self.max_work:g} s of motion in "
                f"all (combinations x seeds x speech seconds)")


DEFAULT_STEPS = (1, 2, 4, 8)          # a sweep's step counts and CFG scales when none are given (page and CLI)
DEFAULT_CFGS = (1.0, DEFAULT_CFG, 3.0)

# the statistics a sweep's plot can show: the keys of motion_stats.STATISTICS and SEED_SPREAD, in their order
# (sweep_report.py checks that they are)
PLOT_METRICS = ("bc", "beat_gain", "loudness_gain", "raised_share", "height_p95", "wrist_speed", "hand_spread", "jerk",
                "diversity", "foot_skate", "contact_share", "drift_per_min", "root_range", "bob", "penetration",
                "leg_jerk", "seed_spread")

__all__ = ["DEFAULT_CFGS", "DEFAULT_STEPS", "PLOT_METRICS", "SweepLimits"]
