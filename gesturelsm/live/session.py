"""Live sessions for a server: one worker thread per stream, bounded queues, clean shutdown, a limit on streams.

    manager = LiveManager(pipe, max_sessions=2)
    session = manager.open()                 # LiveBusy (a message for the visitor) when all streams are in use
    session.feed(chunk)                      # (n,) float32 16 kHz; never blocks; LiveOverloaded if far behind
    for mc in session.poll(): ...            # motion chunks produced so far (MotionChunk)
    session.stop()                           # or session.end() to finish the audio; both join the worker
    manager.open(on_publish=wake)            # wake() is called from the worker when motion is ready (a socket pushes)

A session stops itself when no audio came for `idle_timeout` seconds (tab closed, network gone), so no worker
outlives its visitor. Memory is bounded: at most `max_pending` audio chunks wait, at most `max_ready` motion chunks
wait to be read (older ones are dropped and counted), latencies are kept for the last `LATENCY_KEEP` chunks.
"""
from __future__ import annotations

import logging
import queue
import threading
import time
from collections import deque

import numpy as np
import torch

from ..constants import SAMPLE_RATE
from ..errors import GestureError, Unavailable
from .stream import LiveConfig, MotionChunk, StreamingGenerator

log = logging.getLogger(__name__)
LATENCY_KEEP = 20_000
_END = object()


class LiveBusy(Unavailable):
    """No free live stream; the message is for the visitor."""


class LiveOverloaded(Unavailable):
    """Audio arrives faster than motion can be generated on this machine."""


class LiveEnded(Unavailable):
    """Audio fed to a stream that has ended (stopped, idle too long, or its generation failed); the message says why."""


class LiveSession:
    def __init__(self, pipe, config: LiveConfig = LiveConfig(), max_pending: int = 64, max_ready: int = 256,
                 idle_timeout: float = 30.0, on_close=None, on_publish=None, threads: int | None = None):
        self.gen = StreamingGenerator(pipe, config)
        self.inbox: queue.Queue = queue.Queue(maxsize=max_pending)
        self.outbox: deque[MotionChunk] = deque(maxlen=max_ready)
        self.latencies: deque[float] = deque(maxlen=LATENCY_KEEP)
        self.idle_timeout = idle_timeout
        self.dropped = 0
        self.delivered = 0                     # frames handed out by poll() so far
        self.error: str | None = None
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._on_close = on_close
        self._on_publish = on_publish          # called (from the worker thread) after new motion chunks are ready
        self._closed = False
        self._started = time.perf_counter()
        # the operator's engine stream (relay.py), when this session has it: chunks go on to `sink` as published
        self.sink = None
        self.sink_close = None
        self.engine_note: str | None = None
        # math threads of the worker: `threads`, else the creator's (a new thread would get torch's default)
        self._threads = threads or torch.get_num_threads()
        self._thread = threading.Thread(target=self._work, name="gesturelsm-live", daemon=True)

    # ---- control ---------------------------------------------------------------------------------------------
    def start(self) -> "LiveSession":
        self._thread.start()
        return self

    def feed(self, chunk: np.ndarray) -> None:
        if not self.running:
            raise LiveEnded(self.error or "this live stream has ended")
        try:
            self.inbox.put_nowait((np.asarray(chunk, np.float32).reshape(-1), time.perf_counter()))
        except queue.Full:
            raise LiveOverloaded("the gesture generator cannot keep up with the audio on this machine") from None

    def end(self, timeout: float = 60.0) -> None:
        """The audio is over: generate the rest, then stop the worker."""
        if self._thread.is_alive():
            self.inbox.put((_END, 0.0))
            self._thread.join(timeout)
        self.stop()

    def stop(self, timeout: float = 10.0) -> None:
        """Stop now (the rest of the audio is dropped); joins the worker. Safe to call twice."""
        self._stop.set()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout)
        self._close()

    @property
    def running(self) -> bool:
        return self._thread.is_alive() and not self._stop.is_set()

    def poll(self) -> list[MotionChunk]:
        """Motion chunks produced since the last poll."""
        out = []
        with self._lock:
            while self.outbox:
                out.append(self.outbox.popleft())
        if out:
            self.delivered = out[-1].stop
        return out

    def stats(self) -> dict:
        """Latency (s) median / p90 since the stream started, real-time factor (audio seconds per compute second)."""
        with self._lock:
            lat = np.array(self.latencies)
        g = self.gen
        return {"median_latency_ms": float(np.median(lat) * 1000) if len(lat) else None,
                "p90_latency_ms": float(np.percentile(lat, 90) * 1000) if len(lat) else None,
                "real_time_factor": (g.n_in / SAMPLE_RATE) / g.compute_s if g.compute_s > 0 else None,
                "frames": g.emitted, "audio_seconds": g.n_in / SAMPLE_RATE, "dropped_chunks": self.dropped,
                "running": self.running, "error": self.error, "engines": self.engine_note}

    # ---- worker ----------------------------------------------------------------------------------------------
    def _work(self) -> None:
        torch.set_num_threads(self._threads)
        last = time.perf_counter()
        try:
            while not self._stop.is_set():
                try:
                    chunk, arrival = self.inbox.get(timeout=0.1)
                except queue.Empty:
                    if time.perf_counter() - last > self.idle_timeout:
                        self.error = f"no audio for {self.idle_timeout:.0f} s: the stream was closed"
                        break
                    continue
                last = time.perf_counter()
                if chunk is _END:
                    self._publish(self.gen.finish())
                    break
                self._publish(self.gen.feed(chunk, arrival))
        except GestureError as exc:             # e.g. audio the generator cannot use: the visitor reads why
            self.error = f"live generation failed: {exc}"
        except Exception:                       # a bug: its traceback goes to the log, the visitor reads one line
            log.exception("live generation failed")
            self.error = "live generation failed (an internal error; the server's log has the details)"
        finally:
            self._stop.set()
            self._close()

    def _publish(self, chunks: list[MotionChunk]) -> None:
        with self._lock:
            for c in chunks:
                if len(self.outbox) == self.outbox.maxlen:
                    self.dropped += 1
                self.outbox.append(c)
                self.latencies.extend(c.latencies)
        if chunks and self.sink is not None:
            try:
                self.sink(chunks)
            except Exception:                   # the page's stream goes on without the engines
                log.exception("sending the live stream to the engines failed")
                self.engine_note = "the stream to this server's engine failed (the server's log has the details)"
                self.sink = None
        if chunks and self._on_publish:
            self._on_publish()

    def _close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
            while True:                          # free waiting audio
                try:
                    self.inbox.get_nowait()
                except queue.Empty:
                    break
        if self.sink_close is not None:
            self.sink_close()
        if self._on_close:
            self._on_close(self)


class LiveManager:
    """Hands out at most `max_sessions` live sessions at once; the rest get LiveBusy."""

    def __init__(self, pipe, max_sessions: int = 2, config: LiveConfig = LiveConfig(), relay=None, **session_kw):
        """`relay`: the operator's engine addresses (relay.py EngineRelay): one session at a time streams there."""
        self.pipe, self.max_sessions, self.config, self.session_kw = pipe, max_sessions, config, session_kw
        self.relay = relay
        self._active: set[LiveSession] = set()
        self._lock = threading.Lock()

    def open(self, config: LiveConfig | None = None, on_publish=None) -> LiveSession:
        """A new running session; `on_publish()` is called from its worker whenever motion is ready to poll."""
        with self._lock:
            if len(self._active) >= self.max_sessions:
                raise LiveBusy(f"All {self.max_sessions} live streams are in use right now; please try again in a "
                               "minute (or use the Generate tab, which queues).")
            s = LiveSession(self.pipe, config or self.config, on_close=self._release, on_publish=on_publish,
                            **self.session_kw)
            self._active.add(s)
        if self.relay is not None:
            try:
                self.relay.attach(s)
            except Exception:                   # the page's stream goes on without the engines
                log.exception("the live stream could not be sent to the engines")
                s.engine_note = "the stream to this server's engine could not start (the server's log has why)"
        return s.start()

    def _release(self, session: LiveSession) -> None:
        with self._lock:
            self._active.discard(session)

    @property
    def active(self) -> int:
        with self._lock:
            return len(self._active)

    def stop_all(self) -> None:
        with self._lock:
            sessions = list(self._active)
        for s in sessions:
            s.stop()
