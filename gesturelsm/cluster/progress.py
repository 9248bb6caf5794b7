"""Progress over units with an estimate of the time left, for the command line.

`Tally` counts finished and failed units and estimates the time left from the cost done so far (throughput, so
the estimate holds for one process and for a cluster alike). `ProgressLine` (progress.Line, the command line's one
renderer) draws it on stderr: one line redrawn in place on a terminal (`[ 60 %] 6/10 videos, 1 failed, about 1m20s
left: v_3f2a...`), in a log the first, one line at each tenth of the units and the last.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

from ..progress import Line


def duration(seconds: float) -> str:
    """12 -> '12s', 95 -> '1m35s', 4000 -> '1h06m'."""
    s = int(round(seconds))
    if s < 60:
        return f"{s}s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s // 3600}h{s % 3600 // 60:02d}m"


@dataclass
class Tally:
    total: int                       # units to run (finished ones skipped before are not counted)
    total_cost: float
    noun: str = "units"
    done: int = 0
    failed: int = 0
    cost_done: float = 0.0
    started: float = field(default_factory=lambda: time.perf_counter())

    def finish(self, cost: float, ok: bool) -> None:
        self.done += 1
        self.failed += int(not ok)
        self.cost_done += cost

    @property
    def fraction(self) -> float:
        return self.cost_done / self.total_cost if self.total_cost > 0 else 1.0

    @property
    def seconds_left(self) -> float | None:
        if self.cost_done <= 0:
            return None
        return (time.perf_counter() - self.started) / self.cost_done * max(self.total_cost - self.cost_done, 0.0)

    def message(self, last: str = "") -> str:
        left = self.seconds_left
        parts = [f"{self.done}/{self.total} {self.noun}"]
        if self.failed:
            parts.append(f"{self.failed} failed")
        if self.done < self.total and left is not None:
            parts.append(f"about {duration(left)} left")
        elif self.done == self.total:
            parts.append(f"in {duration(time.perf_counter() - self.started)}")
        return ", ".join(parts) + (f": {last}" if last else "")


# the command line's one progress renderer (gesturelsm/progress.py): a run's `Tally.message` is a counted series
ProgressLine = Line


__all__ = ["ProgressLine", "Tally", "duration"]
