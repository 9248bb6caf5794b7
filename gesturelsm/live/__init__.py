"""Live mode: speech in, motion out, continuously (stream.py: the generator in streaming form; session.py: threaded
sessions with bounded queues and a limit on simultaneous streams for the web app; `gesturelsm live` is
commands/live.py)."""
from .stream import LiveConfig, MotionChunk, StreamingGenerator

__all__ = ["LiveConfig", "MotionChunk", "StreamingGenerator"]
