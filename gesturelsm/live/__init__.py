"""Live mode: speech in, motion out, continuously (stream.py: the generator in streaming form; session.py: threaded
sessions with bounded queues and a limit on simultaneous streams for the web app; `gesturelsm live` is
commands/live.py). Its settings (config.py) load without torch; the other names below are imported from their
modules on first use."""
from __future__ import annotations

from typing import TYPE_CHECKING

from ..lazy import lazy_names
from .config import LiveConfig

_HOME = {"MotionChunk": "stream", "StreamingGenerator": "stream"}

if TYPE_CHECKING:
    from .stream import MotionChunk, StreamingGenerator


__getattr__ = lazy_names(__name__, _HOME)


__all__ = ["LiveConfig", "MotionChunk", "StreamingGenerator"]
