"""Progress, one way everywhere: a `Progress` callback `(fraction done 0-1, what is being done)`; `span`, the part of
a callback one step of the work fills (a sub-range; spans compose); the stages of each kind of work declared once,
by name (`Stages`: `GENERATION`, `REQUEST`, `SWEEP_REQUEST`), so that no step remaps fractions by hand; and the
command line's one renderer, `Line`.

    prog = REQUEST.span(progress, "methods")           # the methods' own 0..1 is 12..62 % of a web request
    pipe.generate_each(speech, plan, progress=prog)    # which spans each method's share of it in turn
    pipe.generate(speech, settings=s, progress=Line()) # on stderr: one line redrawn on a terminal, a few in a log
"""
from __future__ import annotations

import re
import sys
import threading
import time
from typing import TextIO

from .constants import Progress


def span(progress: Progress | None, start: float, end: float, prefix: str = "") -> Progress | None:
    """`progress` over [start, end]: a report (f, m) of the part's own 0..1 is `progress(start + (end - start) * f,
    prefix + m)`. A span of a span is a sub-range of the sub-range. None (nobody listens) stays None."""
    if progress is None:
        return None

    def report(fraction: float, message: str) -> None:
        progress(start + (end - start) * fraction, prefix + message)
    return report


class Stages:
    """The named stages of one kind of work, in order, each the sub-range of the whole it fills (0 <= start <= end
    <= 1, none before the one above it ends)."""

    def __init__(self, **stages: tuple[float, float]):
        last = 0.0
        for name, (start, end) in stages.items():
            if not last <= start <= end <= 1.0:
                raise ValueError(f"stage {name} ({start}, {end}) is not within [{last}, 1] in order")
            last = end
        self._stages = dict(stages)

    def __getitem__(self, name: str) -> tuple[float, float]:
        return self._stages[name]

    def __iter__(self):
        return iter(self._stages)

    def at(self, name: str) -> float:
        """Where the stage begins (a step that says only that it started)."""
        return self._stages[name][0]

    def span(self, progress: Progress | None, name: str, prefix: str = "") -> Progress | None:
        """`progress` over the stage (`span`)."""
        return span(progress, *self._stages[name], prefix=prefix)


# one generation (GesturePipeline.generate and edit): the speech prepared (prepare_speech reports its steps at 0.1
# and 0.2), the method's windows sampled and decoded, then the motion finished and `done` at 1
GENERATION = Stages(speech=(0.0, 0.2), method=(0.2, 0.9))
# one web request (serve/): its speech read and prepared, its methods made (each its share in turn), the video
# rendered (its place in the render queue said at the start), the downloads written, `done` at 1
REQUEST = Stages(speech=(0.02, 0.12), methods=(0.12, 0.62), video=(0.62, 0.92), exports=(0.93, 1.0))
# a sweep as one web request (serve/sweep.py): its speech prepared, then every cell and seed (the sweep's own
# time-left estimate), its table written
SWEEP_REQUEST = Stages(speech=(0.0, 0.1), sweep=(0.1, 0.95))

_COUNT = re.compile(r"^(.*?)(\d+)/(\d+)(.*)$", re.S)     # "gesturelsm: window 3/2250", "frame 12/300 (25 fps)"


class Line:
    """The command line's progress renderer: a `Progress` that writes on `stream` (default: stderr, as it is when
    called) one line per step, `[ 10 %] audio features`. A series of counted steps (a message with `k/n`: a
    sampler's windows, a render's frames, a run's units; a new series when the text before the count or `n`
    changes, or the count starts over) is one line redrawn in place on a terminal; in a log, its first step, one
    line at each `steps`-th of the series and its last, each after the first saying the seconds since it where the
    count follows its noun (`[ 27 %] gesturelsm: window 225/2250 (12.3 s since window 1)`): a 30-minute motion's
    2,250 windows are 11 lines. `write(text)` puts a line of its own (a unit's result) without breaking the
    redrawn one. Reports may come from several threads (the words recognised beside the windows sampled)."""

    def __init__(self, stream: TextIO | None = None, steps: int = 10):
        self._stream = stream
        self.steps = steps
        self._series: tuple[str, int] | None = None     # (the text before the count, n) of the series under way
        self._last, self._step, self._t0, self._open = 0, -1, 0.0, False
        self._lock = threading.Lock()

    @property
    def stream(self) -> TextIO:
        return self._stream if self._stream is not None else sys.stderr

    @property
    def tty(self) -> bool:
        return bool(getattr(self.stream, "isatty", lambda: False)())

    def __call__(self, fraction: float, message: str) -> None:
        with self._lock:
            self._report(fraction, message)

    def _report(self, fraction: float, message: str) -> None:
        line = f"[{100 * fraction:3.0f} %] {message}"
        m = _COUNT.match(message)
        if m is None:
            self._close()
            self._put(line + "\n")
            return
        head, i, n = m.group(1), int(m.group(2)), int(m.group(3))
        if self._series != (head, n) or i <= self._last:          # a new series
            self._close()
            self._series, self._step, self._t0 = (head, n), -1, time.perf_counter()
        self._last, step = i, i * self.steps // max(n, 1)
        if self.tty:
            self._put("\r\033[K" + line + ("\n" if i >= n else ""))
            self._open = i < n
        elif self._step < 0 or step > self._step or i >= n:
            noun = head.split()[-1] if head.split() else ""
            since = f" ({time.perf_counter() - self._t0:.1f} s since {noun} 1)" if noun and self._step >= 0 else ""
            self._put(line + since + "\n")
            self._step = step

    def write(self, text: str) -> None:
        """A line of its own; a series' redrawn line is drawn again at its next step."""
        with self._lock:
            if self._open:
                self.stream.write("\r\033[K")
                self._open = False
            self._put(text + "\n")

    def _close(self) -> None:
        if self._open:
            self.stream.write("\n")
            self._open = False

    def _put(self, text: str) -> None:
        self.stream.write(text)
        self.stream.flush()


__all__ = ["GENERATION", "Line", "Progress", "REQUEST", "SWEEP_REQUEST", "Stages", "span"]
