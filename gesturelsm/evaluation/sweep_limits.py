"""What a sweep may hold, what it runs with when nothing is given, which settings it varies, fixes or takes and what
it measures, without torch: `gesturelsm sweep`, the page's Sweep tab, serve/sweep.py and evaluation/sweep.py read
them from here."""
from __future__ import annotations

from dataclasses import dataclass

from ..settings import DEFAULT_CFG, Setting, settings_of


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

SWEPT = ("steps", "ddim_steps", "cfg", "seed")          # the settings a sweep's grid varies
# the post-processing a sweep's measurement fixes (`sweep_cell`): the raw motion, unsmoothed, not stood in place
MEASURED_POST = {"stand_in_place": False, "smoothing": "off"}
# what a sweep measures, said in its table (the page's Sweep tab, sweep.md, `gesturelsm sweep`, sweep.json): each
# motion as the method sampled it (`output="raw"`), not the finished motion `generate` and the page show; grounded
# unless its grounding setting is off, unsmoothed (MEASURED_POST)
MEASURES = "raw motion, not the finished motion: {grounded}, unsmoothed"


def measures(grounding: bool) -> str:
    """"raw motion, not the finished motion: grounded, unsmoothed" (or "not grounded"): what a sweep's statistics
    were measured on (MEASURES)."""
    return MEASURES.format(grounded="grounded" if grounding else "not grounded")


def sweep_settings(cls: type | None = None) -> tuple[Setting, ...]:
    """The settings a sweep takes one value of (its request's settings part, checked by the settings' validator):
    every setting of the settings object `cls` but those its grid varies (SWEPT) and those its measurement fixes
    (MEASURED_POST): the methods, feet on the ground, transcription, language and any setting added."""
    return tuple(s for s in settings_of(cls) if s.name not in SWEPT and s.name not in MEASURED_POST)


__all__ = ["DEFAULT_CFGS", "DEFAULT_STEPS", "MEASURED_POST", "MEASURES", "PLOT_METRICS", "SWEPT", "SweepLimits",
           "measures", "sweep_settings"]
