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
    ├── Cancelled             work stopped because its result is not wanted
    ├── ClusterError          a cluster that cannot be used (unreachable, other versions, too few CPUs), or
    │                         units of a distributed run that failed every try
    └── UserError             any other problem with a command's arguments
Modules add their own subclasses beside the code that raises them (e.g. `retarget.CharacterError`, an InputError).
Every GestureError is also a ValueError, and Unavailable a RuntimeError, so code that catches those keeps working.
"""
from __future__ import annotations


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


class Cancelled(GestureError):
    """Work stopped because whoever asked for it does not want its result (e.g. a page that shows newer motion)."""


class ClusterError(GestureError):
    """A Ray cluster that cannot be used (unreachable, other versions, the package missing on its workers, too few
    CPUs), or work units that failed on every try; the message names the address or the units and what to do."""


class UserError(GestureError):
    """An error caused by a command's arguments; printed without a traceback."""


__all__ = ["GestureError", "InputError", "AudioError", "TextGridError", "MotionFileError", "DatasetError",
           "BodyModelError", "CheckpointError", "Unavailable", "RenderError", "Cancelled", "ClusterError",
           "UserError"]
