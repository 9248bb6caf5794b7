"""The page's video step: `steps` renders a result's video in the server's render queue (`serve/renders.py`) on a
thread of its own and yields the page's outputs meanwhile, the summary saying where the video is (its place in the
queue, then frame k/n and the time left), then the video. When Gradio closes the step (the page that asked left),
the video is cancelled at once, waiting or rendering; so it is when the page asks for newer motion (`replaced()`).
"""
from __future__ import annotations

import logging
import threading
import gradio as gr

from gesturelsm.errors import GestureError
from gesturelsm.render.background import RenderCancelled
from gesturelsm.serve.request import Result

log = logging.getLogger("gesturelsm.app")
SKIP = (gr.skip(), gr.skip(), gr.skip(), gr.skip())


class VideoStatus:
    """A render's newest progress line, handed from the thread that renders to the step that shows it."""

    def __init__(self, every_s: float = 1.0, progress=None):
        self.every_s, self.progress = every_s, progress
        self.message: str | None = None
        self.closed = False                  # the step was closed: the page that asked is gone
        self._ended = False
        self._cond = threading.Condition()

    def set(self, fraction: float, message: str) -> None:
        if self.progress is not None:
            self.progress(fraction, desc=message)
        with self._cond:
            self.message = message
            self._cond.notify_all()

    def finish(self) -> None:
        with self._cond:
            self._ended = True
            self._cond.notify_all()

    def close(self) -> None:
        self.closed = True

    def updates(self):
        """Each new line, at most one per `every_s`, until the render ends."""
        shown = None
        while True:
            with self._cond:
                self._cond.wait_for(lambda: self._ended or self.message != shown, timeout=self.every_s)
                if self._ended:
                    return
                message = self.message
            if message is not None and message != shown:
                shown = message
                yield message
                with self._cond:                 # at most one line per every_s: the page redraws the summary
                    self._cond.wait_for(lambda: self._ended, timeout=self.every_s)


def last(steps):
    """The last of `steps`' outputs (a step run to its end)."""
    out = None
    for out in steps:
        pass
    return out


def steps(h, out: Result | None, character, request, progress=None):
    """(video, table, summary, state) for the page of `h` (ui._Handlers): the summary with where the video is, each
    time that changes, then the video, the state's new value while no newer request replaced it (`h._kept`); SKIP
    when the video was not needed (the page's newer request replaced it) or was cancelled. `request`: the page
    session's (its older video is superseded by this one)."""
    if out is None or h._replaced(request, out):
        yield (None, *SKIP[1:]) if out is None else SKIP
        return
    status = VideoStatus(progress=progress)
    done: dict = {}

    def work() -> None:
        try:
            done["out"] = h.service.render(out, progress=status.set, character=character,
                                           owner=request.session_hash if request is not None else None,
                                           cancelled=lambda: status.closed or h._replaced(request, out))
        except BaseException as exc:            # handed to the step's thread below
            done["error"] = exc
        finally:
            status.finish()
    worker = threading.Thread(target=work, name="gesturelsm-video", daemon=True)
    worker.start()
    try:
        for message in status.updates():
            yield gr.skip(), gr.skip(), out.summary_with(message), gr.skip()
    finally:
        if worker.is_alive():                    # closed before the video came: the page is gone
            status.close()
    worker.join()
    exc = done.get("error")
    if isinstance(exc, RenderCancelled):
        log.info("a video was not finished: %s", exc)
        yield SKIP
        return
    if isinstance(exc, GestureError):
        h.refuse(exc)
    if exc is not None:
        raise exc
    new = done["out"]
    yield str(new.video), new.table, new.summary, h._kept(request, new)
