"""The Live tab's server side: the tab builds inside a Blocks; microphone chunks (int16, 48 kHz) stream motion records
(base64 in the hidden textbox) and the median latency out; the stop button ends the stream; a busy message past the
limit; a closed tab stops it."""
from __future__ import annotations

import base64
import threading

import numpy as np
import pytest

from gesturelsm.export.motion_codec import AXIS_ANGLE, QUATERNION, MotionRecord, decode
from gesturelsm.live import LiveConfig
from gesturelsm.live.session import LiveManager

from _support import speech_like

gr = pytest.importorskip("gradio")
live = pytest.importorskip("gesturelsm.webapp.live")


def mic_chunks(seconds: float, sr: int = 48000, every: float = 0.2):
    import scipy.signal

    y = scipy.signal.resample_poly(speech_like(seconds, seed=7), 3, 1)
    n = int(sr * every)
    return [(sr, (y[a:a + n] * 32767).astype(np.int16)) for a in range(0, len(y), n)]


def record(text: str) -> MotionRecord:
    """The hidden textbox's value: one motion record, base64."""
    return decode(base64.b64decode(text), "live-motion")


def test_tab_builds_with_the_latency_element(shipped_pipe):
    with gr.Blocks() as demo:
        routes = live.add_live_tab(LiveManager(shipped_pipe, config=LiveConfig(steps=1)))
    ids = [getattr(b, "elem_id", None) for b in demo.blocks.values()]
    assert "live-latency" in ids and "live-motion" in ids and "live-grounding" in ids
    assert routes == []                                 # no body: Gradio's microphone, no socket to serve
    box = next(b for b in demo.blocks.values() if getattr(b, "elem_id", None) == "live-grounding")
    assert box.value is True                            # feet on the ground by default


def test_with_a_body_and_the_player_built_the_tab_serves_the_socket_route_it_is_given(shipped_pipe, tmp_path):
    """live.py names the socket's path for the player and serves the route its caller hands in (ui.py hands
    live_socket.routes): without one, the tab is Gradio's microphone."""
    from gesturelsm.body.model import resolve_body
    from gesturelsm.webapp import live_socket
    from gesturelsm.webapp.player.component import BUNDLE

    if not BUNDLE.exists():
        pytest.skip(f"the player bundle {BUNDLE} is not built (scripts/setup.sh builds it with npm)")
    manager, body = LiveManager(shipped_pipe, config=LiveConfig(steps=1)), resolve_body(None)
    with gr.Blocks() as demo:
        routes = live.add_live_tab(manager, body, tmp_path, socket_routes=live_socket.routes)
    assert [r.path for r in routes] == [live.PATH]
    html = next(b for b in demo.blocks.values() if getattr(b, "elem_id", None) == "live-player-box")
    assert f'data-socket="{live.PATH.lstrip("/")}"' in html.html_template
    assert '<input id="live-grounding" type="checkbox" checked>' in html.html_template   # the hello's grounding
    with gr.Blocks() as demo:
        assert live.add_live_tab(manager, body, tmp_path) == []
    assert "live-mic" in [getattr(b, "elem_id", None) for b in demo.blocks.values()]


def test_stream_then_stop_gives_all_frames_and_latency(shipped_pipe):
    mgr = LiveManager(shipped_pipe, max_sessions=1, config=LiveConfig(steps=1))
    state, frames, seen = None, [], []
    for ch in mic_chunks(3.0):
        state, text, lat, stats, status = live.on_chunk(mgr, ch, state)
        r = record(text)
        assert r.start == sum(frames)                                   # chunks continue where the last ended
        assert r.kind == AXIS_ANGLE and r.rotations.shape[1:] == (55, 3)   # SMPL-X poses, 165 numbers per frame
        frames.append(r.frames)
        seen.append(lat)
    state, text, lat, stats, status = live.on_stop(state)
    r = record(text)
    frames.append(r.frames)
    d = r.meta
    assert sum(frames) == 90 == d["frames"]                                 # 3 s at 30 fps
    assert float(lat) > 0 and d["median_latency_ms"] == pytest.approx(float(lat), abs=1)
    assert f"p90 {d['p90_latency_ms']:.0f} ms" in stats and "real-time factor" in stats
    assert state is None and mgr.active == 0
    assert not [t for t in threading.enumerate() if t.name == "gesturelsm-live"]


def test_busy_message_and_closed_tab(shipped_pipe):
    mgr = LiveManager(shipped_pipe, max_sessions=1, config=LiveConfig(steps=1))
    ch = mic_chunks(0.4)[0]
    s1, *_ = live.on_chunk(mgr, ch, None)
    s2, text, lat, stats, status = live.on_chunk(mgr, ch, None)
    assert s2 is None and "in use" in status and "in use" in record(text).meta["status"]
    live._delete(s1)                                                   # what Gradio calls when the tab closes
    assert mgr.active == 0 and not s1.running


def test_player_arrays_are_the_streamed_poses_on_the_body(shipped_pipe):
    """With the page's body, each record carries the in-browser player's arrays for exactly the frames the same stream
    gives without a body (streams are deterministic): quaternions that rotate like the axis-angle poses (plus the
    body's pose mean) and the root = trans + rest pelvis."""
    from gesturelsm.body.model import resolve_body
    from gesturelsm.export.player_payload import motion_arrays
    from gesturelsm.motion.sequence import MotionSequence

    body = resolve_body(None)
    runs = []
    for b in (None, body):
        session = LiveManager(shipped_pipe, max_sessions=1, config=LiveConfig(steps=1)).open()
        got = []
        for ch in mic_chunks(2.0):
            session.feed(live.to_float(*ch))
            got.append(decode(live.payload(session, "streaming", b)[0]))
        session.end(timeout=10.0)
        runs.append(got + [decode(live.payload(session, "stopped", b)[0])])
    plain, player = runs
    n_all = 0
    for p, d in zip(plain, player):
        n = p.frames
        assert d.start == p.start and d.frames == n and (p.kind, d.kind) == (AXIS_ANGLE, QUATERNION)
        n_all += n
        if not n:
            continue
        seq = MotionSequence(poses=p.rotations.reshape(n, 165), trans=p.root,
                             expressions=np.zeros((n, 100), np.float32))
        want = motion_arrays(seq, body)
        dots = np.abs((d.rotations * want["rotations"]).sum(-1))            # q and -q are the same rotation
        np.testing.assert_allclose(dots, 1.0, atol=1e-5)
        np.testing.assert_allclose(d.root, want["root"], atol=1e-5)
    assert n_all == 60
    first = next(d for d in player if d.frames).root[0]
    np.testing.assert_allclose(first[[0, 2]], body.rest_joints()[0][[0, 2]], atol=1e-4)   # starts at x = z = 0


def test_closing_the_app_stops_its_live_streams(shipped_pipe, tmp_path):
    """`demo.close()` ends every running live session and joins its worker (none outlives the server)."""
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.service import GestureService
    from gesturelsm.webapp.ui import serve_locally

    service = GestureService(shipped_pipe, ServiceSettings(workdir=str(tmp_path)))
    demo, _ = serve_locally(service)
    try:
        session = demo.live.open(LiveConfig(steps=1))
        session.feed(speech_like(1.0, seed=3))
        assert demo.live.active == 1 and session._thread.is_alive()
    finally:
        demo.close()
    assert demo.live.active == 0
    assert not session._thread.is_alive()


def test_the_microphone_streams_grounded_unless_the_option_is_off(shipped_pipe):
    """Gradio's microphone path: the live-grounding checkbox's value opens the stream grounded or not; the upper body
    is the same either way, the legs are not."""
    from _standing import KEPT_COLUMNS

    mgr = LiveManager(shipped_pipe, max_sessions=1, config=LiveConfig(steps=1))
    poses = {}
    for on in (True, False):
        state, parts = None, []
        for ch in mic_chunks(2.0):
            state, text, *_ = live.on_chunk(mgr, ch, state, on)
            parts.append(record(text).rotations)
        assert state.gen.cfg.grounding is on
        state, text, *_ = live.on_stop(state)
        parts.append(record(text).rotations)
        poses[on] = np.concatenate(parts).reshape(-1, 165)
    assert np.array_equal(poses[True][:, KEPT_COLUMNS], poses[False][:, KEPT_COLUMNS])
    assert not np.allclose(poses[True][:, 3:9], poses[False][:, 3:9])


def test_the_operators_vmc_address_gets_one_live_stream_and_a_second_visitor_is_told(shipped_pipe, capsys):
    """`python -m app --vmc` (live/relay.py): the first visitor's Live tab stream goes to the operator's address while
    they speak (a loopback receiver decodes 55 HumanBodyBones per bundle); a second visitor at the same time streams
    on their page only, and their stats line says so; a bad address is one line and status 2."""
    from _osc import Receiver, decode_bundle
    from gesturelsm.export.engine_stream import parse_address
    from gesturelsm.live.relay import BUSY_NOTE, EngineRelay
    from gesturelsm.commands.serve import build_parser, engine_relay, run_demo

    rx = Receiver()
    try:
        relay = engine_relay(build_parser().parse_args(["--vmc", rx.address]))
        assert isinstance(relay, EngineRelay) and relay.vmc == parse_address(rx.address)
        mgr = LiveManager(shipped_pipe, max_sessions=2, config=LiveConfig(steps=1), relay=relay)
        first, second = None, None
        for ch in mic_chunks(2.0):
            first, *_ = live.on_chunk(mgr, ch, first)
            second, _, _, stats2, _ = live.on_chunk(mgr, ch, second)
        rx.wait_for(30, timeout=20)
        assert len(rx.packets) >= 30                                    # sent while the visitor speaks
        _, _, _, stats1, _ = live.on_stop(first)
        _, _, _, stats2, _ = live.on_stop(second)
        relay.wait_sent(20)                                              # the sender drains its queue
    finally:
        rx.close()
    assert "this server's engine (VMC)" in stats1 and BUSY_NOTE in stats2
    assert 30 <= len(rx.packets) <= 60     # 2 s at 30 fps, the first stream only (a loaded machine drops some)
    msgs = decode_bundle(rx.packets[-1][1])
    assert sum(m[0] == "/VMC/Ext/Bone/Pos" for m in msgs) == 55
    assert relay.owner is None and mgr.active == 0
    assert run_demo(build_parser().parse_args(["--vmc", "127.0.0.1"]), "python -m app") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--vmc" in err[0]
