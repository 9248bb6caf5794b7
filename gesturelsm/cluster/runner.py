"""Run independent units of work (a study video, a sweep cell, an evaluation clip) in this process or as Ray tasks,
through the same functions, so that a unit's result does not depend on where it ran.

    job = Job(work=render_one, build=load_models, spec=ModelsSpec(...))     # module-level functions
    report = run_units(job, [Unit("v_1a2b", inputs), ...], on_result=write_files, connection=conn)
    report.raise_failures("videos")                                       # ClusterError listing what failed

- `build(spec)` makes what every unit needs (a pipeline, a body model) once per process: once here, once per Ray
  worker (kept for the run; `built=` hands over objects this process already has). `work(built, inputs)` makes one
  unit's result. Inputs and results travel with the task (no shared disk); `spec` goes to each node once through
  Ray's object store.
- `on_result(unit, result)` runs here, in the order units finish: the caller writes files (whole, `write_atomic`),
  so a unit's files appear once, whichever worker made them.
- On a cluster, a unit whose worker or node dies is run again (Ray's task retries, `retries` times); a unit that
  raises is not (the same inputs raise again) and is listed in the report with its one-line reason, while the
  others go on. At most `in_flight` units are queued at once, so inputs of thousands of units never sit in memory
  together. `cancelled` (an errors.CancelToken, or a predicate; asked between units) stops the run: queued units
  are cancelled, nothing more is written (errors.Cancelled).
- Progress goes to `progress(fraction, message)` with the time left, estimated from each unit's `cost`.
"""
from __future__ import annotations

import logging
import traceback
import uuid
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Sequence

from ..constants import Progress
from ..errors import Cancellable, CancelToken, Cancelled, ClusterError, GestureError
from .connect import Connection
from .progress import Tally

log = logging.getLogger("gesturelsm.cluster")
RETRIES = 3                              # extra tries of a unit whose worker or node died


@dataclass(frozen=True)
class Job:
    """What every unit of one run shares; `work` and `build` are module-level functions (workers import them)."""
    work: Callable[[Any, Any], Any]
    build: Callable[[Any], Any]
    spec: Any = None


@dataclass(frozen=True)
class Unit:
    key: str                             # unique within a run: the name a failure is listed under
    inputs: Any = field(repr=False)
    cost: float = 1.0                    # relative cost, for the estimate of the time left
    label: str = ""                      # what the unit is, for people (e.g. "alpha.wav, ddim")


@dataclass(frozen=True)
class Failure:
    key: str
    label: str
    reason: str                          # one line

    def __str__(self) -> str:
        return f"{self.key}{f' ({self.label})' if self.label else ''}: {self.reason}"


@dataclass
class RunReport:
    done: list[str] = field(default_factory=list)
    failed: list[Failure] = field(default_factory=list)

    def raise_failures(self, noun: str = "units") -> None:
        """ClusterError listing every failed unit (one line each) when any failed."""
        if self.failed:
            total = len(self.done) + len(self.failed)
            lines = "\n".join(f"  {f}" for f in self.failed)
            raise ClusterError(f"{len(self.failed)} of {total} {noun} failed on every try:\n{lines}")


# the run was cancelled on request; units not finished were not written
Stopped = Cancelled
STOPPED = "Stopped on request; the units not finished were not written."


def run_units(job: Job, units: Sequence[Unit], on_result: Callable[[Unit, Any], None], *,
              connection: Connection | None = None, built: Any = None, progress: Progress | None = None,
              cancelled: Cancellable | None = None, retries: int = RETRIES, cpus: float = 1.0,
              in_flight: int | None = None, noun: str = "units", keep_going: bool = True) -> RunReport:
    """Every unit through `job` (module docstring); returns which were done and which failed. `keep_going=False`
    (this process only): the first failure raises its own exception, as a plain loop would."""
    if len({u.key for u in units}) != len(units):
        raise ValueError("two units share a key")
    tally = Tally(len(units), sum(u.cost for u in units) or 1.0, noun)
    cancelled = CancelToken.of(cancelled)
    report = RunReport()
    if progress and units:
        progress(0.0, tally.message())
    if connection is None:
        _run_here(job, units, on_result, built, tally, report, progress, cancelled, keep_going)
    else:
        _run_on_ray(job, units, on_result, tally, report, progress, cancelled, retries, cpus,
                    in_flight or max(2, int(2 * connection.cpus / max(cpus, 1e-9))))
    return report


def _finished(unit: Unit, result: Any, error: str | None, on_result, tally: Tally, report: RunReport,
              progress: Progress | None) -> None:
    if error is None:
        on_result(unit, result)
        report.done.append(unit.key)
    else:
        report.failed.append(Failure(unit.key, unit.label, error))
    tally.finish(unit.cost, error is None)
    if progress:
        progress(tally.fraction, tally.message(unit.key))


def _reason(exc: BaseException, remote: str | None = None) -> str:
    """One line: a GestureError's own message; anything else is a bug, its traceback goes to the log (`remote`: the
    traceback as the worker saw it)."""
    if isinstance(exc, GestureError):
        return " | ".join(str(exc).splitlines())
    log.error("a unit failed:\n%s", (remote or "".join(traceback.format_exception(exc))).rstrip())
    first = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {first[0] if first else ''}"


def _run_here(job: Job, units: Sequence[Unit], on_result, built, tally, report, progress, cancelled,
              keep_going: bool) -> None:
    built = job.build(job.spec) if built is None else built
    for unit in units:
        cancelled.check(Cancelled, STOPPED)
        try:
            result, error = job.work(built, unit.inputs), None
        except Exception as exc:
            if not keep_going:
                raise
            result, error = None, _reason(exc)
        _finished(unit, result, error, on_result, tally, report, progress)


# ---- on a Ray cluster ----------------------------------------------------------------------------------------
_BUILT: dict[str, Any] = {}              # run id -> what `build` made, in a worker process (the latest run only)


def _remote_unit(run: str, build, work, spec_box: list, inputs):
    """The task: build once per worker process and run (the spec arrives boxed so Ray fetches it only when
    needed)."""
    if run not in _BUILT:
        import ray

        _BUILT.clear()
        _BUILT[run] = build(ray.get(spec_box[0]))
    return work(_BUILT[run], inputs)


def _run_on_ray(job: Job, units: Sequence[Unit], on_result, tally, report, progress, cancelled, retries: int,
                cpus: float, window: int) -> None:
    import ray
    from ray.exceptions import RayTaskError, TaskCancelledError

    task = ray.remote(_remote_unit).options(num_cpus=cpus, max_retries=retries, retry_exceptions=False)
    run, spec_box = uuid.uuid4().hex, [ray.put(job.spec)]
    waiting: Iterable[Unit] = iter(units)
    pending: dict = {}
    try:
        while True:
            for unit in waiting:
                pending[task.remote(run, job.build, job.work, spec_box, unit.inputs)] = unit
                if len(pending) >= window:
                    break
            if not pending:
                return
            cancelled.check(Cancelled, STOPPED)
            ready, _ = ray.wait(list(pending), num_returns=1, timeout=1.0)
            for ref in ready:
                unit = pending.pop(ref)
                try:
                    result, error = ray.get(ref), None
                except RayTaskError as exc:                     # the unit's own code raised: not retried
                    cause = exc.cause if isinstance(exc.cause, BaseException) else exc
                    result, error = None, _reason(cause, str(exc))
                except TaskCancelledError:
                    raise
                except ray.exceptions.RayError as exc:          # its worker or node died on every try
                    result, error = None, (f"the worker running it was lost {retries + 1} times "
                                           f"({type(exc).__name__})")
                _finished(unit, result, error, on_result, tally, report, progress)
    finally:
        for ref in pending:
            ray.cancel(ref, force=True)


__all__ = ["Failure", "Job", "RETRIES", "RunReport", "Stopped", "Unit", "run_units"]
