"""The Live tab's WebSocket (gesturelsm/webapp/live_socket.py), driven by Starlette's test client: int16 PCM in,
motion records (gesturelsm/export/motion_codec.py) out as soon as they exist; every frame of the speech arrives once,
in order, whatever the sample rate; Stop generates the rest
and closes; busy, bad messages and dropped connections end cleanly (no live worker left)."""
from __future__ import annotations

import json
import threading

import numpy as np
import pytest
import scipy.signal

from gesturelsm.export.motion_codec import AXIS_ANGLE, QUATERNION, MotionRecord, decode
from gesturelsm.live import LiveConfig
from gesturelsm.live.session import LiveManager

from _support import speech_like, until

pytest.importorskip("gradio")
live_socket = pytest.importorskip("gesturelsm.webapp.live_socket")
from starlette.applications import Starlette  # noqa: E402
from starlette.testclient import TestClient  # noqa: E402


def workers() -> int:
    return sum(t.name == "gesturelsm-live" and t.is_alive() for t in threading.enumerate())


def wait_idle(mgr: LiveManager) -> None:
    until(lambda: mgr.active == 0 and workers() == 0, "every live stream ended and its worker stopped")


@pytest.fixture()
def client_for(shipped_pipe):
    def make(max_sessions: int = 1, body=None):
        mgr = LiveManager(shipped_pipe, max_sessions=max_sessions, config=LiveConfig(steps=1))
        return mgr, TestClient(Starlette(routes=live_socket.routes(mgr, body)))
    return make


def pcm_blocks(seconds: float, sr: int, block_s: float = 0.1) -> list[bytes]:
    y = speech_like(seconds, seed=7)
    if sr != 16000:
        y = scipy.signal.resample_poly(y, sr, 16000)
    n = int(sr * block_s)
    return [(np.clip(y[a:a + n], -1, 1) * 32767).astype("<i2").tobytes() for a in range(0, len(y), n)]


def receive(ws) -> MotionRecord:
    """The next message: one binary motion record."""
    return decode(ws.receive_bytes(), "socket message")


def stream(client, blocks, sr: int, **hello) -> list[MotionRecord]:
    with client.websocket_connect(live_socket.PATH) as ws:
        ws.send_text(json.dumps({"sample_rate": sr, **hello}))
        for b in blocks:
            ws.send_bytes(b)
        ws.send_text(json.dumps({"end": True}))
        out = []
        while not out or out[-1].meta["status"] == "streaming":
            out.append(receive(ws))
    return out


@pytest.mark.parametrize("sr", [16000, 48000])
def test_streamed_speech_comes_back_as_every_frame_once_in_order(client_for, sr):
    mgr, client = client_for()
    msgs = stream(client, pcm_blocks(3.0, sr), sr)
    assert msgs[-1].meta["status"] == "stopped"
    assert all(m.meta["status"] == "streaming" for m in msgs[:-1])
    n = 0
    for m in msgs:
        assert m.start == n                                           # contiguous: no gap, no overlap
        n += m.frames
        assert m.kind == AXIS_ANGLE and m.rotations.shape[1:] == (55, 3) and m.root.shape == (m.frames, 3)
    last = msgs[-1].meta
    assert n == 90 == last["frames"]                                       # 3 s at 30 fps, as offline
    assert last["audio_seconds"] == pytest.approx(3.0, abs=1e-3)
    assert last["median_latency_ms"] > 0 and last["p90_latency_ms"] >= last["median_latency_ms"]
    wait_idle(mgr)


def test_motion_arrives_while_the_speech_is_still_streaming(client_for):
    """Pushed by the worker, not at Stop: the first motion message comes before the end is sent."""
    mgr, client = client_for()
    with client.websocket_connect(live_socket.PATH) as ws:
        ws.send_text(json.dumps({"sample_rate": 16000}))
        for b in pcm_blocks(2.0, 16000):
            ws.send_bytes(b)
        first = receive(ws)                                           # blocks until the worker publishes
        assert first.meta["status"] == "streaming" and first.start == 0 and first.frames > 0
    wait_idle(mgr)                                                      # closing the socket stopped the session


def test_the_page_body_gets_the_players_arrays(client_for):
    from gesturelsm.body.model import resolve_body

    mgr, client = client_for(body=resolve_body(None))
    msgs = stream(client, pcm_blocks(1.5, 16000), 16000)
    n = sum(m.frames for m in msgs)
    assert n == 45 and all(m.kind == QUATERNION and m.rotations.shape[1:] == (55, 4) for m in msgs)
    wait_idle(mgr)


def test_past_the_limit_the_visitor_reads_busy(client_for):
    mgr, client = client_for(max_sessions=1)
    with client.websocket_connect(live_socket.PATH) as first:
        first.send_text(json.dumps({"sample_rate": 16000}))
        first.send_bytes(pcm_blocks(0.1, 16000)[0])
        until(lambda: mgr.active == 1, "the first stream opened")
        with client.websocket_connect(live_socket.PATH) as second:
            second.send_text(json.dumps({"sample_rate": 16000}))
            assert "in use" in receive(second).meta["status"]
        assert mgr.active == 1                                          # the first stream is untouched
    wait_idle(mgr)


@pytest.mark.parametrize("hello, then, says", [
    ("hello", None, "sample_rate"),
    (json.dumps({"sample_rate": 1000}), None, "not supported"),
    (json.dumps({"sample_rate": 16000}), b"\x01\x02\x03", "16-bit PCM"),
    (json.dumps({"sample_rate": 16000}), "not json", "must be JSON"),
    (json.dumps({"sample_rate": 16000}), b"\x00\x00" * 16000 * 6, "at most 5 s"),
    (json.dumps({"sample_rate": 16000, "grounding": "no"}), None, "grounding must be true or false"),
])
def test_bad_messages_get_a_clear_message_and_end_the_stream(client_for, hello, then, says):
    mgr, client = client_for()
    with client.websocket_connect(live_socket.PATH) as ws:
        ws.send_text(hello)
        if isinstance(then, bytes):
            ws.send_bytes(then)
        elif then is not None:
            ws.send_text(then)
        assert says in receive(ws).meta["status"]
    wait_idle(mgr)


def test_a_stream_that_goes_quiet_is_closed_with_its_reason(shipped_pipe):
    """No audio for the session's idle timeout (a page that stopped sending): the server says why and closes."""
    mgr = LiveManager(shipped_pipe, max_sessions=1, config=LiveConfig(steps=1), idle_timeout=0.5)
    client = TestClient(Starlette(routes=live_socket.routes(mgr)))
    with client.websocket_connect(live_socket.PATH) as ws:
        ws.send_text(json.dumps({"sample_rate": 16000}))
        ws.send_bytes(pcm_blocks(0.1, 16000)[0])
        assert "no audio" in receive(ws).meta["status"]
        assert ws.receive()["type"] == "websocket.close"
    wait_idle(mgr)


def test_a_socket_that_names_no_sample_rate_is_closed(client_for, monkeypatch):
    monkeypatch.setattr(live_socket, "HELLO_TIMEOUT_S", 0.2)
    mgr, client = client_for()
    with client.websocket_connect(live_socket.PATH) as ws:
        assert "no sample rate" in receive(ws).meta["status"]
    assert mgr.active == 0


def test_the_hello_turns_feet_on_the_ground_off_for_its_stream(client_for):
    """The page's live-grounding checkbox goes with the hello: by default the stream is grounded (its legs and root
    differ from the decoder's), with "grounding": false it is the decoder's; the upper body is the same either way."""
    from _standing import KEPT_COLUMNS

    mgr, client = client_for()
    got = {}
    for key, hello in (("default", {}), ("off", {"grounding": False}), ("on", {"grounding": True})):
        msgs = stream(client, pcm_blocks(2.0, 16000), 16000, **hello)
        got[key] = (np.concatenate([m.rotations for m in msgs]).reshape(-1, 165),
                    np.concatenate([m.root for m in msgs]))
        wait_idle(mgr)
    (p_on, r_on), (p_off, r_off) = got["default"], got["off"]
    np.testing.assert_array_equal(got["on"][0], p_on)
    assert np.array_equal(p_on[:, KEPT_COLUMNS], p_off[:, KEPT_COLUMNS])
    assert not np.allclose(p_on[:, 3:9], p_off[:, 3:9]) and not np.allclose(r_on, r_off)
