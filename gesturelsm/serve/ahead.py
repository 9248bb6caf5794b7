"""Motion made ahead of the click, with the settings the page shows, and handed to the click that asks for exactly
them.

When the page's speech is uploaded (or its settings change), `GestureService.prefetch` prepares the speech and then,
while the visitor reads the settings, starts making the methods those settings ask for in a thread of its own
(`Ahead.start`). A click whose request makes the same motion (the same upload and transcript settings, methods, steps,
CFG, seed and post-processing: `motion_key`) takes that run (`Ahead.take`) and is shown each method as the run makes
it, the ones already made at once. A click that asks for anything else cancels the run and generates as always. The
motion is the same either way: the run is `GesturePipeline.generate_each` with the request's own plan and seed.

One run at a time in the whole server: a new one cancels the one before unless a click has taken it. A run is not
started while the server generates for a click or something else says it is busy (`busy`, e.g. live streams), and a
click for other motion cancels it, so work made ahead does not take the cores from generation asked for (it may run
beside a video rendering, as a request does: renders run niced in a process of their own). A cancelled run stops at
its next window. The settings as the page shows them are a guess of what the click will ask for, so a run
is work that may be thrown away: it is never made for a server that has no idle core time to give (see `busy`).
"""
from __future__ import annotations

import contextlib
import logging
import threading
import time
from typing import Callable, Hashable, Iterator

from ..errors import CancelToken, Interrupted
from ..generator.sampling import window_previews
from ..pipeline import Made, Plan
from ..settings import motion_values
from .preview import Preview

log = logging.getLogger("gesturelsm.app")


# raised inside a run's progress callback to stop it at its next window: the family's BaseException kind, so that a
# method's own error handling (`generate_each(keep_going=True)`) does not record it as that method's failure
Cancelled = Interrupted


def motion_key(upload: Hashable, speech: Hashable, plan: Plan) -> Hashable:
    """What a request's motion depends on: the upload (`prepared.file_key`), the transcript settings it was prepared
    for, and the plan: every setting that changes the motion (`settings.motion_values`: methods, steps, CFG, seed,
    post-processing, ...) and where ground truth is looked up."""
    return (upload, speech, motion_values(plan.settings), plan.beat2, plan.filename)


class Run:
    """One run made ahead: the methods made so far, in the order they were made."""

    def __init__(self, key: Hashable, busy: Callable[[], bool] = lambda: False, what: str = ""):
        self.key, self.busy, self.what = key, busy, what
        self.made: list[Made] = []
        self.made_at: list[float] = []         # time.perf_counter() when each was made
        self.started_at: float | None = None   # when the run began making (after the run before it stopped)
        self.done = False
        self.failed = False                    # cancelled, or stopped by an error of the server's (not finished)
        self.cancelled = CancelToken()
        self.taken = False
        self._cond = threading.Condition()
        self.thread: threading.Thread | None = None
        self.preview = Preview(self._cond)     # the first method's windows as they are made (serve/preview.py)
        self.said: tuple[float, str] | None = None   # the last progress of a run made for a click (`say`)
        self.error: BaseException | None = None      # what stopped a run made for a click

    def add(self, x: Made) -> None:
        with self._cond:
            self.made.append(x)
            self.made_at.append(time.perf_counter())
            if x.motion is not None:
                self.preview.stop()
            self._cond.notify_all()

    def say(self, f: float, message: str) -> None:
        """A progress callback for a run made for a click: stops it when cancelled, else keeps what it says for the
        thread that reads the run."""
        self.check()
        with self._cond:
            self.said = (f, message)
            self._cond.notify_all()

    def seconds(self, x: Made) -> float | None:
        """Wall time from the run's start until `x` (one of its methods) was made: the work done ahead up to it."""
        with self._cond:
            i = next((k for k, y in enumerate(self.made) if y is x), None)
            if i is None or self.started_at is None:
                return None
            return self.made_at[i] - self.started_at

    def finish(self, failed: bool = False) -> None:
        with self._cond:
            self.done, self.failed = True, failed
            self._cond.notify_all()

    def check(self, *_) -> None:
        """A progress callback: stops the run when it was cancelled, or, while no click has taken it, when something
        else needs the cores (a live stream started)."""
        if not self.taken and not self.cancelled.is_set() and self.busy():
            self.cancelled.cancel("something else needs the cores")
        self.cancelled.check()

    def items(self) -> Iterator[Made]:
        """Each method as the run makes it (the made ones at once), until the run ends."""
        i = 0
        while True:
            with self._cond:
                while i >= len(self.made) and not self.done:
                    self._cond.wait()
                if i >= len(self.made):
                    return
                x = self.made[i]
            i += 1
            yield x


class Ahead:
    """The server's one run made ahead (module docstring). `busy()`: whether something else needs the cores (no run is
    started then); requests in flight are counted by `generating`."""

    def __init__(self, busy: Callable[[], bool] = lambda: False):
        self.busy = busy
        self._lock = threading.Lock()
        self._run: Run | None = None
        self._requests = 0

    def start(self, key: Hashable, make: Callable[[Run], Iterator[Made]], what: str = "") -> Run | None:
        """Make `make(run)`'s methods (`what`: their names, for the log) in a thread of its own for requests with
        `key`; the run before is cancelled
        (unless taken). Nothing is started (None) while a request is generated, `busy()` says so, a taken run is still
        being made, or a run for the same key exists (also one a click has taken: its motion is on the page)."""
        with self._lock:
            old = self._run
            if old is not None and old.key == key and not old.cancelled.is_set():
                return None
            if self._requests or (old is not None and old.taken and not old.done) or self.busy():
                return None
            if old is not None and not old.taken:
                old.cancelled.set()
            run = self._run = Run(key, self.busy, what)
            run.thread = threading.Thread(target=self._make, args=(run, make, old), daemon=True,
                                          name="gesturelsm-ahead")
            try:
                run.thread.start()
            except RuntimeError:                   # no thread to be had: nothing is made ahead
                log.exception("making motion ahead could not start")
                run.cancelled.set()
                run.finish(failed=True)
                return None
        return run

    @staticmethod
    def _make(run: Run, make: Callable[[Run], Iterator[Made]], before: Run | None) -> None:
        failed = False
        try:
            if before is not None and before.thread is not None and before.thread.ident is not None:
                before.thread.join()               # one run on the cores at a time: the cancelled one stops first
            run.check()
            run.started_at = time.perf_counter()
            log.info("making motion ahead: %s", run.what)
            with window_previews(run.preview):     # the first method shown as its windows come
                for x in make(run):                # its windows check for cancelling (make's progress: run.check)
                    run.add(x)
        except Cancelled:                          # only a run no click has taken is cancelled
            failed = True
            log.info("motion made ahead was cancelled after %d method(s)", len(run.made))
        except Exception:                          # a bug: logged; the click generates for itself
            log.exception("making motion ahead failed")
            failed = True
        finally:
            run.finish(failed)

    def take(self, key: Hashable) -> Run | None:
        """The run for `key` (the click then reads it: `Run.items`), else None; any other run not taken is cancelled,
        since this click needs the cores."""
        with self._lock:
            run = self._run
            if run is None or run.taken:
                return None
            if run.key != key or run.cancelled.is_set() or (run.done and run.failed):
                run.cancelled.set()
                return None
            run.taken = True
            return run

    @contextlib.contextmanager
    def generating(self) -> Iterator[None]:
        """A context in which a request is counted as generating (no run is started meanwhile)."""
        with self._lock:
            self._requests += 1
        try:
            yield
        finally:
            with self._lock:
                self._requests -= 1

    def cancel(self) -> None:
        """Cancel the run unless a click has taken it."""
        with self._lock:
            if self._run is not None and not self._run.taken:
                self._run.cancelled.set()

    def stop(self, timeout: float | None = None) -> None:
        """Cancel the run (unless taken) and wait for its thread to end."""
        self.cancel()
        run = self._run
        if run is not None and run.thread is not None and run.thread.ident is not None:
            run.thread.join(timeout)

