"""A cancelled render stops at once: `render_apart`'s `cancelled()` is asked every 0.1 s by a watcher, so the render
process is killed also before its first frame (framing the camera on a long motion), its partial file removed and
RenderCancelled raised; the render queue's slot it held is then free for the next video (serve/renders.py)."""
from __future__ import annotations

import threading

import pytest

import gesturelsm.render.background as bg
from gesturelsm.render.background import RenderCancelled, render_apart
from gesturelsm.serve.renders import RenderQueue


def test_a_cancelled_render_process_ends_and_frees_its_slot(tmp_path, make_pose):
    queue = RenderQueue(slots=1)
    ticket = queue.enter("page-1")
    ticket.wait()
    started, outcome = threading.Event(), {}

    def render() -> None:
        try:
            with ticket:
                render_apart([make_pose(9000, -1.2)], None, tmp_path / "req" / "v.mp4", size=(64, 64), nice=5,
                             progress=lambda f, m: started.set(), cancelled=ticket.cancelled.is_set)
        except BaseException as exc:
            outcome["error"] = exc
    thread = threading.Thread(target=render)
    thread.start()
    assert started.wait(120)                                    # the render process runs (it said so)
    with bg._lock:
        procs = list(bg._running)
    assert len(procs) == 1 and procs[0].poll() is None
    other = queue.enter("page-2")
    assert other.position == 1 and queue.running == 1
    assert queue.cancel("page-1") == 1                          # its page closed
    thread.join(60)
    assert not thread.is_alive() and isinstance(outcome.get("error"), RenderCancelled)
    assert procs[0].poll() is not None                          # the process has ended
    with bg._lock:
        assert not bg._running
    assert not (tmp_path / "req" / "v.mp4").exists()
    assert [p.name for p in (tmp_path / "req").iterdir()] == []   # no partial file, no job folder
    other.wait()                                                 # the slot is free: the next video's turn
    assert other.position == 0 and queue.running == 1
    other.done()
    assert queue.running == 0 and queue.waiting == 0


def test_a_render_cancelled_before_its_first_frame_stops(tmp_path, make_pose):
    with pytest.raises(RenderCancelled):
        render_apart([make_pose(600, -1.2)], None, tmp_path / "w.mp4", size=(32, 32), nice=5, cancelled=lambda: True)
    assert not (tmp_path / "w.mp4").exists()
    with bg._lock:
        assert not bg._running


def test_a_cancelled_token_stops_a_render_with_its_reason_kept(tmp_path, make_pose):
    from gesturelsm.errors import Cancelled, CancelToken

    token = CancelToken()
    token.cancel("a newer request of the same page replaced it")
    with pytest.raises(Cancelled, match="the render was cancelled"):
        render_apart([make_pose(600, -1.2)], None, tmp_path / "w.mp4", size=(32, 32), nice=5, cancelled=token)
    assert not (tmp_path / "w.mp4").exists() and token.reason.startswith("a newer request")
