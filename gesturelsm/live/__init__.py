"""Live mode: speech in, motion out, continuously (stream.py: the generator in streaming form; session.py: threaded
sessions with bounded queues and a limit on simultaneous streams for the web app; `gesturelsm live` is
commands/live.py). Its settings (config.py) load without torch; the other names below are imported from their
modules on first use."""
from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .config import LiveConfig

_HOME = {"MotionChunk": "stream", "StreamingGenerator": "stream"}

if TYPE_CHECKING:
    from .stream import MotionChunk, StreamingGenerator


def __getattr__(name: str) -> Any:
    if name not in _HOME:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{_HOME[name]}", __name__), name)
    globals()[name] = value
    return value


__all__ = ["LiveConfig", "MotionChunk", "StreamingGenerator"]
