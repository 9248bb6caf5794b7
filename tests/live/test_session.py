"""Live sessions: start, feed, stop midway (no worker left), several at once, the limit, idle streams, same motion
as the plain streaming generator."""
from __future__ import annotations

import threading

import numpy as np
import pytest

from gesturelsm.live import LiveConfig, StreamingGenerator
from gesturelsm.live.session import LiveBusy, LiveManager

from _support import speech_like, until

CFG = LiveConfig(steps=1)


def live_threads() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name == "gesturelsm-live" and t.is_alive()]


@pytest.fixture(scope="module")
def speech(beat2_root):
    from gesturelsm.audio import load_audio

    return load_audio(beat2_root / "wave16k" / "2_scott_0_2_2.wav")[:16000 * 6]


def test_stop_midway_leaves_no_worker(shipped_pipe, speech):
    mgr = LiveManager(shipped_pipe, max_sessions=2, config=CFG)
    s = mgr.open()
    for a in range(0, len(speech) // 2, 3200):
        s.feed(speech[a:a + 3200])
    until(lambda: s.gen.emitted > 0, "the session made motion")
    assert s.poll()
    s.stop()
    assert not s._thread.is_alive() and live_threads() == [] and mgr.active == 0
    with pytest.raises(RuntimeError, match="ended"):
        s.feed(speech[:3200])
    st = s.stats()
    assert st["median_latency_ms"] is not None and not st["running"]


def test_session_output_equals_the_streaming_generator(shipped_pipe, speech):
    mgr = LiveManager(shipped_pipe, max_sessions=1, config=CFG)
    s = mgr.open()
    for a in range(0, len(speech), 3200):
        s.feed(speech[a:a + 3200])
    s.end()
    got = np.concatenate([c.motion.poses for c in s.poll()])
    ref = np.concatenate([c.motion.poses for c in StreamingGenerator(shipped_pipe, CFG).stream(
        [speech[a:a + 3200] for a in range(0, len(speech), 3200)])])
    np.testing.assert_array_equal(got, ref)
    assert len(got) == len(speech) * 30 // 16000 and live_threads() == [] and mgr.active == 0


def test_limit_gives_a_clear_busy_message_and_frees_on_stop(shipped_pipe, speech):
    mgr = LiveManager(shipped_pipe, max_sessions=2, config=CFG)
    a, b = mgr.open(), mgr.open()
    with pytest.raises(LiveBusy, match="2 live streams are in use"):
        mgr.open()
    for s in (a, b):                                   # both stream at once
        for k in range(0, 16000 * 2, 3200):
            s.feed(speech[k:k + 3200])
    until(lambda: a.gen.emitted > 0 and b.gen.emitted > 0, "both sessions made motion")
    a.stop()
    c = mgr.open()                                     # a freed its place
    mgr.stop_all()
    assert mgr.active == 0 and live_threads() == [] and not c.running


def test_idle_stream_stops_itself(shipped_pipe):
    mgr = LiveManager(shipped_pipe, max_sessions=1, config=CFG, idle_timeout=0.3)
    s = mgr.open()
    s.feed(speech_like(0.4))
    until(lambda: not s.running, "the idle stream stopped itself")
    assert "no audio" in s.stats()["error"]
    until(lambda: mgr.active == 0, "the idle stream gave its place back")
    assert live_threads() == []


def test_outbox_is_bounded_when_nobody_reads(shipped_pipe):
    mgr = LiveManager(shipped_pipe, max_sessions=1, config=CFG, max_ready=2)
    s = mgr.open()
    y = speech_like(4.0)
    for a in range(0, len(y), 3200):
        s.feed(y[a:a + 3200])
    s.end()
    assert len(s.poll()) == 2 and s.stats()["dropped_chunks"] > 0
