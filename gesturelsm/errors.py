"""The package's one error family: every problem a person can fix (bad input, bad settings, a file that cannot
be used, rendering that cannot run here) is a `GestureError` whose message is meant for that person: what is
wrong and what to do. The app turns `GestureError` into a message on the page, the CLI into one line on stderr
(exit status 2); anything else is a bug and keeps its traceback.

    GestureError
    ├── InputError            input or settings a person must change (pipeline settings, speech length ...)
    │   ├── AudioError        audio that cannot be read or used
    │   ├── TextGridError     a TextGrid that cannot be read or written
    │   ├── MotionFileError   a motion file that is not BEAT2 / SMPL-X
    │   ├── DatasetError      a dataset folder or file that cannot be used
    │   ├── BodyModelError    a body model file that cannot be used
    │   └── CheckpointError   a model file that cannot be used
    ├── RenderError           rendering cannot run here (no OpenGL backend, context creation failed)
    ├── ClusterError          a cluster that cannot be used (unreachable, other versions, too few CPUs), or
    │                         units of a distributed run that failed every try
    └── UserError             any other problem with a command's arguments
All are ValueErrors (RenderError is also a RuntimeError), as they were before the family existed.
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


class RenderError(GestureError, RuntimeError):
    """Rendering cannot run here (no OpenGL backend, context creation failed); the message says why."""


class ClusterError(GestureError):
    """A Ray cluster that cannot be used (unreachable, other versions, the package missing on its workers, too few
    CPUs), or work units that failed on every try; the message names the address or the units and what to do."""


class UserError(GestureError):
    """An error caused by a command's arguments; printed without a traceback."""


__all__ = ["GestureError", "InputError", "AudioError", "TextGridError", "MotionFileError", "DatasetError",
           "BodyModelError", "CheckpointError", "RenderError", "ClusterError", "UserError"]
