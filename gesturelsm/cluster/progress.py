"""Progress over units with an estimate of the time left, for the command line.

`Tally` counts finished and failed units and estimates the time left from the cost done so far (throughput, so
the estimate holds for one process and for a cluster alike). `ProgressLine` draws it on stderr: one line redrawn
in place on a terminal (`[######----]  60 %  6/10 videos, 1 failed, about 1m20s left: v_3f2a...`), a new line at
most every `every` seconds otherwise (logs, CI).
"""
from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from typing import TextIO


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


class ProgressLine:
    """A `Progress` callable (fraction, message) that draws a bar on stderr."""

    def __init__(self, stream: TextIO | None = None, width: int = 24, every: float = 5.0):
        self.stream = stream or sys.stderr
        self.width, self.every = width, every
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._last = -1e9
        self._open = False

    def __call__(self, fraction: float, message: str) -> None:
        now = time.perf_counter()
        final = fraction >= 1.0
        if not self.tty and not final and now - self._last < self.every:
            return
        self._last = now
        full = int(round(self.width * min(max(fraction, 0.0), 1.0)))
        line = f"[{'#' * full}{'-' * (self.width - full)}] {100 * fraction:3.0f} %  {message}"
        if self.tty:
            self.stream.write("\r\033[K" + line[:200] + ("\n" if final else ""))
            self._open = not final
        else:
            self.stream.write(line + "\n")
        self.stream.flush()

    def write(self, text: str) -> None:
        """A log line that does not break the bar (the bar is drawn again on the next update)."""
        if self._open:
            self.stream.write("\r\033[K")
            self._open = False
        self.stream.write(text + "\n")
        self.stream.flush()


__all__ = ["ProgressLine", "Tally", "duration"]
