"""The server's videos: rendered a few at a time (`slots`), the others waiting in line, first come first served, and
none of them able to hold up anybody else's once nobody wants it.

Each render enters the line with a `Ticket` and its owner (the page session that asked for it, None for an API call):

    ticket = queue.enter(owner)                 # the owner's older tickets are cancelled: superseded
    ticket.wait(report=lambda position: ...)    # blocks until a slot is free; position 1 = next in line
    try:
        render(..., cancelled=ticket.cancelled)     # a CancelToken: the render process is killed once it is set
    finally:
        ticket.done()                           # the slot goes to the next in line

A ticket is cancelled, and its entry leaves the line at once (or its render process is killed and its slot freed),
when its owner asks for newer motion (`enter` again: superseded), when its page closes or its session ends
(`cancel(owner)`: the page's unload and the handler's closed generator call it), or by `Ticket.cancel`. Nothing here
renders: `GestureService.render` does, inside a ticket's turn (`render/background.py` kills the process).
"""
from __future__ import annotations

import itertools
import re
import threading
import time
from typing import Callable, Hashable

from ..errors import CancelToken
from ..render.background import RenderCancelled

SUPERSEDED = "a newer request of the same page replaced it"
CLOSED = "its page was closed"


class Ticket:
    """One render's place in the line (`RenderQueue.enter`)."""

    def __init__(self, queue: "RenderQueue", owner: Hashable | None, number: int):
        self.queue, self.owner, self.number = queue, owner, number
        self.cancelled = CancelToken()
        self.reason = ""
        self.entered = time.monotonic()
        self.started: float | None = None          # when its turn came (monotonic)

    def cancel(self, reason: str = "cancelled") -> None:
        self.queue._cancel([self], reason)

    @property
    def position(self) -> int:
        """0: rendering; k: k-th in line (k - 1 renders wait before it); -1: done or cancelled."""
        return self.queue.position(self)

    def wait(self, report: Callable[[int], None] | None = None, cancelled: Callable[[], bool] | None = None,
             poll_s: float = 0.2) -> None:
        """Block until this ticket's turn; `report(position)` each time its place in the line changes (first at
        once). RenderCancelled when it is cancelled meanwhile, or `cancelled()` (asked every `poll_s`) says so: its
        entry has then left the line."""
        q, last = self.queue, None
        while True:
            if cancelled is not None and not self.cancelled.is_set() and cancelled():
                self.cancel("cancelled")
            with q._cond:
                while True:
                    if self.cancelled.is_set():
                        raise RenderCancelled(f"the video was not rendered: {self.reason}")
                    if q._waiting and q._waiting[0] is self and len(q._running) < q.slots:
                        q._waiting.pop(0)
                        q._running.append(self)
                        self.started = time.monotonic()
                        q._cond.notify_all()
                        return
                    position = q._waiting.index(self) + 1
                    if position != last:
                        break
                    q._cond.wait(poll_s)
                    if cancelled is not None:       # asked outside the lock
                        break
            if position != last and report is not None:
                report(position)
            last = position

    def done(self) -> None:
        """This ticket's render ended (made, failed or cancelled): its slot, or its place in line, goes."""
        q = self.queue
        with q._cond:
            if self in q._running:
                q._running.remove(self)
            if self in q._waiting:
                q._waiting.remove(self)
            q._cond.notify_all()

    def __enter__(self) -> "Ticket":
        return self

    def __exit__(self, *exc) -> None:
        self.done()

    def __repr__(self) -> str:
        return f"Ticket({self.number}, owner={self.owner!r}, position={self.position})"


class RenderQueue:
    """Renders `slots` at a time, the rest waiting in arrival order (module docstring). Thread-safe."""

    def __init__(self, slots: int = 1):
        self.slots = max(1, int(slots))
        self._cond = threading.Condition()
        self._running: list[Ticket] = []
        self._waiting: list[Ticket] = []
        self._numbers = itertools.count(1)

    def enter(self, owner: Hashable | None = None) -> Ticket:
        """A ticket at the end of the line; the owner's tickets before it are cancelled (superseded)."""
        with self._cond:
            old = [t for t in self._running + self._waiting if owner is not None and t.owner == owner]
            ticket = Ticket(self, owner, next(self._numbers))
            self._waiting.append(ticket)
        self._cancel(old, SUPERSEDED)
        return ticket

    def supersede(self, owner: Hashable) -> int:
        """Cancel every ticket of `owner`, whose newer request replaced them; returns how many."""
        return self.cancel(owner, SUPERSEDED)

    def cancel(self, owner: Hashable, reason: str = CLOSED) -> int:
        """Cancel every ticket of `owner` (waiting ones leave the line, running ones' renders are killed); returns
        how many."""
        with self._cond:
            tickets = [t for t in self._running + self._waiting if t.owner == owner]
        self._cancel(tickets, reason)
        return len(tickets)

    def _cancel(self, tickets: list[Ticket], reason: str) -> None:
        with self._cond:
            for t in tickets:
                if not t.cancelled.is_set():
                    t.reason = reason
                    t.cancelled.cancel(reason)
                if t in self._waiting:              # its entry goes now; a running one frees its slot when killed
                    self._waiting.remove(t)
            self._cond.notify_all()

    def position(self, ticket: Ticket) -> int:
        with self._cond:
            if ticket in self._running:
                return 0
            if ticket in self._waiting:
                return self._waiting.index(ticket) + 1
            return -1

    @property
    def running(self) -> int:
        with self._cond:
            return len(self._running)

    @property
    def waiting(self) -> int:
        with self._cond:
            return len(self._waiting)


def video_progress(progress: Callable[[float, str], None]) -> Callable[[float, str], None]:
    """A render's progress (`render_apart`'s fraction and "frame k/n (x fps)") as the visitor reads it: "rendering:
    frame k/n, about S s left", the time left from the frame rate so far (since the first frame)."""
    first: list[tuple[float, float]] = []

    def report(fraction: float, message: str) -> None:
        m = _FRAME.search(message)
        if m is None:
            progress(fraction, f"rendering: {message}" if message else "rendering")
            return
        k, n = int(m.group(1)), int(m.group(2))
        now = time.monotonic()
        if not first:
            first.append((now, fraction))
            progress(fraction, f"rendering: frame {k}/{n}")
            return
        t0, f0 = first[0]
        rate = (fraction - f0) / max(now - t0, 1e-9)
        left = (1.0 - fraction) / rate if rate > 0 else None
        progress(fraction, f"rendering: frame {k}/{n}" + (f", about {left:.0f} s left" if left is not None else ""))
    return report


_FRAME = re.compile(r"frame (\d+)/(\d+)")


def waiting_line(position: int) -> str:
    """The visitor's line for a video waiting in the queue at `position` (1: next)."""
    ahead = position - 1
    if ahead <= 0:
        return "waiting: next in line, after the video being rendered"
    return f"waiting: queue position {position}, {ahead} video{'s' * (ahead != 1)} ahead of it"


__all__ = ["CLOSED", "RenderQueue", "SUPERSEDED", "Ticket", "video_progress", "waiting_line"]
