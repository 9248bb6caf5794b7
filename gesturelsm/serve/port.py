"""Where a request's motion, video and files are made: the one port the service (`serve/service.py`) generates
through, with two implementations: this process (`serve/local.py` `LocalGeneration`) and Ray Serve replicas
(`serve/replicated.py` `ReplicaGeneration`, `gesturelsm serve --replicas N`). Both take the same values and give the
same `Result`s; what stays with the service whichever makes them: the render queue (one video per page at a time),
the downloads made so far of a result that grows, the Live tab's models.

    service = GestureService(pipeline, settings, body)                   # LocalGeneration
    service = ReplicatedService.start(settings, count, address)          # a GestureService on ReplicaGeneration
    isinstance(service.generation, Generation)                           # True for both
"""
from __future__ import annotations

from typing import Callable, Iterator, Protocol, Sequence, runtime_checkable

import numpy as np

from ..constants import Progress
from ..evaluation.sweep import SweepLimits
from .request import Request, Result
from .sweep import SweepOutcome, SweepRequest


@runtime_checkable
class Generation(Protocol):
    """What the page and the API ask of a server's generation."""

    where: str                       # where it runs, for the log ("this process", "2 replica(s)", ...)
    sweep_note: str                  # where sweeps run when not with the rest, for the page ("": with the rest)

    def run(self, req: Request, progress: Progress | None = None, audio: np.ndarray | None = None) -> Result:
        """One request whole: motion, then its video (`req.render`) and downloads (`req.exports`)."""

    def stream(self, req: Request, progress: Progress | None = None, audio: np.ndarray | None = None,
               previews: bool = True) -> Iterator[Result]:
        """The request's result as it grows, without the video and the downloads (at least the last one)."""

    def edit(self, result: Result, method: str, start, end, regions: Sequence[str] | str, seed,
             progress: Progress | None = None) -> Result:
        """A new result with `method`'s motion regenerated over [start, end] s in `regions` (`serve/editing.py`)."""

    def render(self, result: Result, progress: Progress, cancelled: Callable[[], bool], character=None) -> Result:
        """The result with its video (its turn in the service's render queue has come)."""

    def export(self, result: Result) -> Result:
        """The result with its downloads."""

    def sweep(self, req: SweepRequest, limits: SweepLimits, progress: Progress | None,
              cancelled: Callable[[], bool] | None) -> SweepOutcome:
        """A sweep of methods x steps x CFG x seeds on one upload (`serve/sweep.py`)."""

    def prefetch(self, audio_path: str | None, text: str = "", textgrid_path: str | None = None,
                 transcribe: bool = True, ahead: Request | None = None) -> bool:
        """Work on an upload before the click (`GestureService.prefetch`); whether it was done."""

    def close(self) -> None:
        """Stop what it started (replicas, a cluster)."""


__all__ = ["Generation"]
