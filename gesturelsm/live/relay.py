"""The page's Live tab streamed on to engines (`python -m app --vmc HOST:PORT`, `gesturelsm serve --vmc`): the
operator, and only the operator, names the addresses; one live stream at a time goes there (the first to start; a
second visitor's stream plays on their page only, and their page says so). Each committed chunk's frames leave on a
steady 30 fps clock (export/engine_stream.py), from the session's worker as the chunk is published.

    relay = EngineRelay(parse_address("127.0.0.1:39539"))
    manager = LiveManager(pipe, relay=relay)              # sessions it opens are attached to the relay
"""
from __future__ import annotations

import logging
import threading

from ..body.model import resolve_body
from ..export.engine_stream import Address, EngineStream

log = logging.getLogger(__name__)
BUSY_NOTE = ("another visitor's stream is going to this server's engine (VMC / Live Link) right now: yours plays on "
             "this page only")


class EngineRelay:
    """The operator's engine addresses; `attach(session)` gives the session the stream when it is free."""

    def __init__(self, vmc: Address | None = None, livelink: Address | None = None, perfect_sync: bool = False,
                 body=None) -> None:
        self.vmc, self.livelink, self.perfect_sync = vmc, livelink, perfect_sync
        self.body = resolve_body(body)
        self.owner = None
        self._lock = threading.Lock()
        self._closing: list[threading.Thread] = []

    @property
    def targets(self) -> str:
        return " and ".join(k for k, a in (("VMC", self.vmc), ("Live Link Face", self.livelink)) if a is not None)

    def attach(self, session) -> None:
        """Send `session`'s motion on (if no other session's is going), else note on it why not."""
        with self._lock:
            if self.owner is not None:
                session.engine_note = BUSY_NOTE
                return
            self.owner = session
        try:
            stream = EngineStream(self.vmc, self.livelink, self.perfect_sync, self.body, say=log.info).start()
        except Exception:
            with self._lock:
                self.owner = None
            raise
        session.engine_note = f"also streaming to this server's engine ({self.targets})"
        session.sink = lambda chunks: [stream.push(c.motion) for c in chunks]
        session.sink_close = lambda: self._release(session, stream)

    def _release(self, session, stream: EngineStream) -> None:
        with self._lock:
            if self.owner is session:
                self.owner = None
        closer = threading.Thread(target=stream.close, name="engine-stream-close", daemon=True)
        self._closing = [t for t in self._closing if t.is_alive()] + [closer]
        closer.start()                          # the queued frames still leave on their clock, the session ends now

    def wait_sent(self, timeout: float = 30.0) -> None:
        """Until the ended streams' queued frames have left (for tests and shutdown)."""
        for t in list(self._closing):
            t.join(timeout)
