"""The package's one error family: every problem a person can fix or must be told about (bad input, bad settings, a
file that cannot be used, something this machine or server cannot do) is a `GestureError` whose message is meant for
that person: what is wrong and what to do. The edges (the command line, the page's handlers, the live socket, the
study server) turn a `GestureError` into one line for that person (the CLI: on stderr, exit status 2) and report
anything else as a bug, with its traceback in the log (the CLI: "internal error", exit status 1).

    GestureError
    ├── InputError            input or settings a person must change (pipeline settings, speech length ...)
    │   ├── AudioError        audio that cannot be read or used
    │   ├── TextGridError     a TextGrid that cannot be read or written
    │   ├── MotionFileError   a motion file that is not BEAT2 / SMPL-X
    │   ├── DatasetError      a dataset folder or file that cannot be used
    │   ├── BodyModelError    a body model file that cannot be used
    │   └── CheckpointError   a model file that cannot be used
    ├── Unavailable           what this machine or server cannot do: a missing tool or model, no free stream
    │   └── RenderError       rendering cannot run here (no OpenGL backend, context creation failed)
    ├── Cancelled             work stopped because its result is not wanted (also a Cancellation)
    ├── ClusterError          a cluster that cannot be used (unreachable, other versions, too few CPUs), or
    │                         units of a distributed run that failed every try
    └── UserError             any other problem with a command's arguments
Modules add their own subclasses beside the code that raises them (e.g. `retarget.CharacterError`, an InputError).
Every GestureError is also a ValueError, and Unavailable a RuntimeError, so code that catches those keeps working.

Cancellation, one family and one token. Work whose result is not wanted (a page that asks for newer motion or closed,
a sweep stopped from its tab, motion made ahead for settings the click did not keep) is stopped through a
`CancelToken`: whoever may stop it calls `cancel(reason)`, the work asks `cancelled` or calls `check()` between its
steps. What is raised is a `Cancellation`:

    Cancellation (a BaseException)
    ├── Cancelled             told to a person as one line (a GestureError too: the edges print it as any other)
    └── Interrupted           raised inside the work, through code that is not its own (a progress callback of a
                              generation): not an Exception, as asyncio's CancelledError, so that no `except
                              Exception` on the way (a method's failure recorded while the next one is made,
                              pipeline.generate_each) takes it for the work's own failure; whoever started the work
                              catches it
"""
from __future__ import annotations

import threading
import time
from typing import Callable, Union


class GestureError(ValueError):
    """A problem the person using the package can fix; the message says what and how."""


class InputError(GestureError):
    """Input or settings a person must change; the message says what and how."""


class AudioError(InputError):
    """Audio that cannot be used; the message is meant for the user."""


class TextGridError(InputError):
    """A TextGrid that cannot be read or written; the message names the file and the line."""


class MotionFileError(InputError):
    """A motion file that cannot be read as BEAT2/SMPL-X; the message names the file and the problem."""


class DatasetError(InputError):
    """A dataset folder or file that cannot be used; the message names it."""


class BodyModelError(InputError):
    """A body model file that cannot be used; the message names the file and the problem."""


class CheckpointError(InputError):
    """A model file that cannot be used; the message names the file and the problem."""


class Unavailable(GestureError, RuntimeError):
    """What this machine or server cannot do (a missing tool or model, all live streams in use); the message says
    what is missing or when to try again."""


class RenderError(Unavailable):
    """Rendering cannot run here (no OpenGL backend, context creation failed); the message says why."""


class Cancellation(BaseException):
    """The cancellation family's root: work stopped because whoever asked for it does not want its result."""


class Cancelled(GestureError, Cancellation):
    """Work stopped because whoever asked for it does not want its result (e.g. a page that shows newer motion); the
    message says what was not done."""


class Interrupted(Cancellation):
    """Work stopped at its next step from inside (`CancelToken.check`), through code that is not its own: a
    BaseException, so that a method's own error handling does not record it as that method's failure."""


class ClusterError(GestureError):
    """A Ray cluster that cannot be used (unreachable, other versions, the package missing on its workers, too few
    CPUs), or work units that failed on every try; the message names the address or the units and what to do."""


class UserError(GestureError):
    """An error caused by a command's arguments; printed without a traceback."""


class CancelToken(threading.Event):
    """Whether a piece of work is still wanted (module docstring). Made with others (tokens, or predicates such as
    `lambda: page.closed`), it is cancelled as soon as any of them is: they are asked whenever it is. It is a
    `threading.Event` (`set`, `is_set`, `wait`) and a predicate (`token()`), so that it goes wherever a stop flag or
    a `cancelled()` callable went.

        token = CancelToken(page_closed)       # cancelled by its own `cancel` or once page_closed() says so
        token.cancel("superseded")             # from any thread; the first reason is kept
        token.check()                          # in the work: Interrupted once cancelled
        token.check(Cancelled, "The sweep was cancelled; nothing was written.")    # said to a person
    """

    def __init__(self, *also: "Cancellable"):
        super().__init__()
        self._also = tuple(a for a in also if a is not None)
        self._reason_lock = threading.Lock()
        self.reason = ""

    @classmethod
    def of(cls, x: "Cancellable | None") -> "CancelToken":
        """What an API takes as `cancelled` as a token: a token as it is, a predicate asked whenever the token is,
        None a token that only its own `cancel` cancels."""
        return x if isinstance(x, CancelToken) else cls(x)

    def cancel(self, reason: str = "cancelled") -> bool:
        """Cancel the work; True the first time (its reason is the one kept)."""
        with self._reason_lock:
            first = not super().is_set()
            if first:
                self.reason = reason
                super().set()
        return first

    def set(self) -> None:
        self.cancel()

    def is_set(self) -> bool:
        if super().is_set():
            return True
        for other in self._also:
            if other():
                self.cancel(getattr(other, "reason", "") or "cancelled")
                return True
        return False

    @property
    def cancelled(self) -> bool:
        return self.is_set()

    def __call__(self) -> bool:
        return self.is_set()

    def wait(self, timeout: float | None = None, poll_s: float = 0.1) -> bool:
        """Block until cancelled or `timeout` seconds passed; True when cancelled. With others it asks them every
        `poll_s` seconds."""
        if not self._also:
            return super().wait(timeout)
        end = None if timeout is None else time.monotonic() + timeout
        while not self.is_set():
            left = poll_s if end is None else min(poll_s, end - time.monotonic())
            if left <= 0:
                return False
            super().wait(left)
        return True

    def check(self, error: type[Cancellation] = Interrupted, message: str | None = None) -> None:
        """Raise `error(message, else the reason)` once cancelled; nothing otherwise."""
        if self.is_set():
            raise error(message or self.reason)


Cancellable = Union[CancelToken, Callable[[], bool]]      # what an API takes as `cancelled`


__all__ = ["GestureError", "InputError", "AudioError", "TextGridError", "MotionFileError", "DatasetError",
           "BodyModelError", "CheckpointError", "Unavailable", "RenderError", "Cancellation", "Cancelled",
           "Interrupted", "CancelToken", "Cancellable", "ClusterError", "UserError"]
