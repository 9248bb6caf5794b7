"""Work a page started, stopped when the page closes or reloads (Gradio's `unload`, which fires when the tab's
heartbeat connection ends).

Gradio stops sending to a closed page, but a handler that runs in a worker thread (an edit, a sweep, the sampling
inside Generate) runs on to its end unless it is told: a closed tab would keep a generation slot and a core busy for
nobody. Each handler runs its work inside `PageWork.running(request)`, whose flag `session_ended` sets; the
handler's progress callback (`PageWork.checked`) then raises `PageClosed` at the next step (the next window of a
generation or an edit, the next motion of a sweep), and the handler returns without output. Other pages' work is
not touched: the flags are per page session.

`PageClosed` is the cancellation family's BaseException kind (errors.Interrupted), as asyncio's CancelledError is:
a cancellation, not an error, so that no `except Exception` on the way (a method that fails does not stop the
others, pipeline.generate_each) takes it for a failed method and goes on with the next one. The flags are
errors.CancelToken.
"""
from __future__ import annotations

import contextlib
import logging
import threading
from typing import Callable, Iterable, Iterator

import gradio as gr

from ..errors import CancelToken, Interrupted

log = logging.getLogger("gesturelsm.app")


# the page that asked for this work closed; the work stops here
PageClosed = Interrupted


class PageWork:
    """The stop flags of the work each page session is running (module docstring)."""

    def __init__(self, renders=None):
        self.renders = renders                  # the service's render queue (serve/renders.py), or None
        self._running: dict[str, set[CancelToken]] = {}
        self._lock = threading.Lock()

    def session_ended(self, request: gr.Request = None) -> None:
        """The page closed or reloaded (Gradio's unload): its videos are cancelled, waiting or rendering, and its
        generation, edit or sweep stops at its next step."""
        if request is not None and self.renders is not None and self.renders.cancel(request.session_hash):
            log.info("a page closed: its video was cancelled")
        if self.close(request):
            log.info("a page closed: its running work stops")

    def until_closed(self, request, progress, work: Callable[[Callable], Iterable]) -> Iterator:
        """What `work(report)` yields, `report` being `progress` that stops it (PageClosed) once the page of
        `request` closed; the iteration then ends without more."""
        try:
            with self.running(request) as closed:
                yield from work(self.checked(progress, closed))
        except PageClosed:
            log.info("a page closed during its request: the work stopped")

    @contextlib.contextmanager
    def running(self, request) -> Iterator[CancelToken]:
        """A flag set when `request`'s page closes while the block runs (never set without a page session)."""
        flag = CancelToken()
        key = getattr(request, "session_hash", None)
        if key:
            with self._lock:
                self._running.setdefault(key, set()).add(flag)
        try:
            yield flag
        finally:
            if key:
                with self._lock:
                    flags = self._running.get(key)
                    if flags is not None:
                        flags.discard(flag)
                        if not flags:
                            del self._running[key]

    def close(self, request) -> int:
        """The page of `request` closed: every flag of its running work is set; returns how many."""
        key = getattr(request, "session_hash", None)
        with self._lock:
            flags = self._running.pop(key, set()) if key else set()
        for flag in flags:
            flag.set()
        return len(flags)

    @property
    def pages(self) -> int:
        """Page sessions with work running."""
        with self._lock:
            return len(self._running)

    @staticmethod
    def checked(progress, flag: CancelToken) -> Callable[[float, str], None]:
        """`progress(f, desc=m)` (Gradio's) as the package's (f, m) callback, raising PageClosed once `flag` is set."""
        def report(f: float, m: str) -> None:
            flag.check(PageClosed, "the page closed")
            progress(f, desc=m)
        return report


__all__ = ["PageClosed", "PageWork"]
