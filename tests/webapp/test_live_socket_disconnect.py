"""Visitors who leave: a live-socket client that drops its connection at any stage of the socket's life (before
naming its sample rate, after it, while motion streams, right after Stop, after being refused or told the server is
busy) leaves no traceback and no error in the server's log, and no live worker behind. Served by uvicorn as the app
serves it: Starlette's test client does not reproduce a client that is gone while the server still sends."""
from __future__ import annotations

import json
import logging
import select
import socket
import struct
import threading

import numpy as np
import pytest

from gesturelsm.live import LiveConfig
from gesturelsm.live.session import LiveManager

from _support import free_port, speech_like, until

pytest.importorskip("gradio")
uvicorn = pytest.importorskip("uvicorn")
live_socket = pytest.importorskip("gesturelsm.webapp.live_socket")
from starlette.applications import Starlette  # noqa: E402


@pytest.fixture()
def served(shipped_pipe):
    """(manager, port): the socket route served by uvicorn in a thread, at most one live stream."""
    mgr = LiveManager(shipped_pipe, max_sessions=1, config=LiveConfig(steps=1))
    port = free_port()
    server = uvicorn.Server(uvicorn.Config(Starlette(routes=live_socket.routes(mgr)), host="127.0.0.1", port=port,
                                           log_config=None, log_level="debug"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    until(lambda: server.started, "the socket's server started")
    yield mgr, port
    server.should_exit = True
    thread.join(10)
    mgr.stop_all()


class RawClient:
    """A bare WebSocket client over a socket, so it can vanish without a closing handshake."""

    def __init__(self, port: int):
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=10)
        self.sock.sendall((f"GET {live_socket.PATH} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
                           "Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                           "Sec-WebSocket-Version: 13\r\n\r\n").encode())
        head = b""
        while b"\r\n\r\n" not in head:
            head += self.sock.recv(1)
        assert b" 101 " in head.split(b"\r\n")[0], head

    def send(self, data: bytes | str) -> None:
        opcode, data = (1, data.encode()) if isinstance(data, str) else (2, data)
        n = len(data)
        head = bytes([0x80 | opcode]) + (bytes([0x80 | n]) if n < 126 else bytes([0x80 | 126]) + struct.pack(">H", n))
        mask = b"\x01\x02\x03\x04"
        self.sock.sendall(head + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(data)))

    def drop(self) -> None:
        """Leave at once: reset the connection (no close frame, unread data discarded)."""
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        self.sock.close()


class Handlers:
    """The socket's handlers (`live_socket.serve`, wrapped) running and finished, to wait on instead of sleeping."""

    def __init__(self, serve):
        self.serve, self.running, self.finished, self.lock = serve, 0, 0, threading.Lock()

    async def __call__(self, *args, **kwargs):
        with self.lock:
            self.running += 1
        try:
            return await self.serve(*args, **kwargs)
        finally:
            with self.lock:
                self.running, self.finished = self.running - 1, self.finished + 1


def _pcm(seconds: float) -> list[bytes]:
    y = (np.clip(speech_like(seconds, seed=7), -1, 1) * 32767).astype("<i2")
    return [y[a:a + 1600].tobytes() for a in range(0, len(y), 1600)]


HELLO = json.dumps({"sample_rate": 16000})


def _no_hello(port, mgr, handlers):
    RawClient(port).drop()


def _after_hello(port, mgr, handlers):
    c = RawClient(port)
    c.send(HELLO)
    until(lambda: mgr.active == 1, "the stream opened")
    c.drop()


def _while_streaming(port, mgr, handlers):
    c = RawClient(port)
    c.send(HELLO)
    for b in _pcm(3.0):
        c.send(b)
    assert select.select([c.sock], [], [], 120)[0]   # motion is being pushed to a client that reads none
    c.drop()


def _right_after_stop(port, mgr, handlers):
    c = RawClient(port)
    c.send(HELLO)
    for b in _pcm(2.0):
        c.send(b)
    c.send(json.dumps({"end": True}))    # the server generates the rest, then sends to a client that is gone
    c.drop()


def _refused(port, mgr, handlers):
    c = RawClient(port)
    c.send(json.dumps({"sample_rate": 1}))   # refused: the server sends the reason and closes
    c.drop()


def _busy(port, mgr, handlers):
    first = RawClient(port)
    first.send(HELLO)
    until(lambda: mgr.active == 1, "the first stream opened")
    done = handlers.finished
    second = RawClient(port)
    second.send(HELLO)                   # past the limit: the server sends "busy" to a client that is gone
    second.drop()
    until(lambda: handlers.finished > done, "the second visitor was answered")
    first.drop()


STAGES = [_no_hello, _after_hello, _while_streaming, _right_after_stop, _refused, _busy]


@pytest.mark.parametrize("stage", STAGES, ids=[s.__name__.strip("_") for s in STAGES])
def test_a_client_that_leaves_leaves_no_traceback(served, caplog, monkeypatch, stage):
    from gesturelsm.webapp import live_socket

    mgr, port = served
    handlers = Handlers(live_socket.serve)
    monkeypatch.setattr(live_socket, "serve", handlers)      # the route looks it up at each connection
    caplog.set_level(logging.DEBUG)
    for _ in range(3):
        stage(port, mgr, handlers)
    until(lambda: mgr.active == 0 and handlers.running == 0 and handlers.finished >= 3,
          "every handler finished after the last drop")
    import gc

    gc.collect()                         # "Task exception was never retrieved" is logged when a task is collected
    bad = [f"{r.name} {r.levelname}: {r.getMessage()}" for r in caplog.records
           if r.exc_info or r.levelno > logging.INFO or "Traceback" in r.getMessage()]
    assert bad == []
    assert mgr.active == 0
