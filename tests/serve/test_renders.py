"""The server's render queue (serve/renders.py) and `GestureService.render` in it: videos wait in arrival order and
say their place in line; a page's newer request cancels its older video (superseded), a closed page's videos are
cancelled (their entries leave the line at once, a running one's slot is freed); a waiting video whose `cancelled()`
says so leaves too. The render itself is replaced by a stand-in that runs until cancelled (the real process's kill:
tests/render/test_cancel.py)."""
from __future__ import annotations

import threading
from pathlib import Path

import pytest

import gesturelsm.serve.local as service_module
from gesturelsm.render.background import RenderCancelled
from gesturelsm.serve.renders import CLOSED, SUPERSEDED, RenderQueue, video_progress, waiting_line
from gesturelsm.serve.request import Request


def _waiting(ticket, positions: list, **kw) -> threading.Thread:
    out = {}

    def wait() -> None:
        try:
            ticket.wait(positions.append, **kw)
            out["turn"] = True
        except RenderCancelled as exc:
            out["error"] = exc
    thread = threading.Thread(target=wait)
    thread.out = out
    thread.start()
    return thread


def _until(condition, timeout: float = 30.0) -> None:
    done = threading.Event()
    for _ in range(int(timeout / 0.01)):
        if condition():
            return
        done.wait(0.01)
    raise AssertionError("condition not met")


def test_the_queue_reports_positions_and_cancels_by_owner_and_supersedes():
    q = RenderQueue(slots=1)
    a = q.enter("a")
    a.wait()
    assert a.position == 0 and q.running == 1
    b, c = q.enter("b"), q.enter("c")
    assert (b.position, c.position) == (1, 2)
    seen_c: list[int] = []
    tc = _waiting(c, seen_c)
    _until(lambda: seen_c == [2])                         # its place, said at once
    assert q.cancel("b") == 1                             # b's page closed: its entry leaves the line at once
    assert b.cancelled.is_set() and b.reason == CLOSED and b.position == -1
    _until(lambda: seen_c == [2, 1])                      # c moved up
    c2 = q.enter("c")                                     # the same page asks again: c is superseded
    tc.join(10)
    assert isinstance(tc.out.get("error"), RenderCancelled) and c.reason == SUPERSEDED and c2.position == 1
    seen_c2: list[int] = []
    t2 = _waiting(c2, seen_c2)
    a.done()                                              # a's render ended: its slot goes to the next in line
    t2.join(10)
    assert t2.out.get("turn") and c2.position == 0 and seen_c2 == [1]
    c2.done()
    assert q.running == 0 and q.waiting == 0


def test_a_waiting_ticket_leaves_when_its_check_says_so():
    q = RenderQueue(slots=1)
    a = q.enter("a")
    a.wait()
    gone = threading.Event()
    b = q.enter("b")
    tb = _waiting(b, [], cancelled=gone.is_set)
    gone.set()                                            # e.g. the page's newer motion replaced it
    tb.join(10)
    assert isinstance(tb.out.get("error"), RenderCancelled) and q.waiting == 0
    a.done()


def test_two_slots_render_two_at_once():
    q = RenderQueue(slots=2)
    a, b, c = q.enter(), q.enter(), q.enter()
    a.wait()
    b.wait()
    assert (a.position, b.position, c.position) == (0, 0, 1) and q.running == 2
    for t in (a, b, c):
        t.done()


def test_the_lines_the_visitor_reads():
    assert "next in line" in waiting_line(1) and "queue position 3, 2 videos ahead" in waiting_line(3)
    seen = []
    report = video_progress(lambda f, m: seen.append(m))
    report(0.0, "starting: framing the camera on the motions")
    report(0.01, "frame 1/100 (3.0 fps)")
    report(0.5, "frame 50/100 (3.0 fps)")
    assert seen[0] == "rendering: starting: framing the camera on the motions" and seen[1] == "rendering: frame 1/100"
    assert seen[2].startswith("rendering: frame 50/100, about ") and seen[2].endswith(" s left")


@pytest.fixture
def blocking_render(monkeypatch):
    """render_apart replaced by a stand-in that runs until its `cancelled()` says so (or it is released)."""
    running: dict[str, threading.Event] = {}
    release = threading.Event()

    def render_apart(motions, audio, video, *, progress=None, cancelled=None, **kw):
        name = Path(video).parent.name
        running[name] = threading.Event()
        running[name].set()
        progress(0.5, "frame 50/100 (1.0 fps)")
        while not release.wait(0.01):
            if cancelled():
                raise RenderCancelled("the render was cancelled")
        Path(video).write_bytes(b"mp4")
    monkeypatch.setattr(service_module, "render_apart", render_apart)
    return running, release


def _render(service, result, owner, steps: list) -> threading.Thread:
    out = {}

    def render() -> None:
        try:
            out["result"] = service.render(result, progress=lambda f, m: steps.append(m), owner=owner)
        except RenderCancelled as exc:
            out["error"] = exc
    thread = threading.Thread(target=render)
    thread.out = out
    thread.start()
    return thread


def test_a_closed_page_video_goes_and_the_next_page_renders(service, speech_wav, blocking_render):
    running, release = blocking_render
    req = Request(str(speech_wav), methods=["gesturelsm"], steps=1, size=256, exports=False, render=False)
    first, second = service.run(req), service.run(req)
    s1, s2 = [], []
    t1 = _render(service, first, "page-1", s1)
    _until(lambda: first.job.folder.name in running)
    t2 = _render(service, second, "page-2", s2)
    _until(lambda: any("next in line" in m for m in s2))            # its place in the queue, said
    assert service.cancel_renders("page-1") == 1                     # page 1 closed during its render
    t1.join(10)
    assert isinstance(t1.out.get("error"), RenderCancelled)
    _until(lambda: second.job.folder.name in running)               # page 2's turn came at once
    release.set()
    t2.join(10)
    out = t2.out["result"]
    assert out.video.read_bytes() == b"mp4" and service.renders.running == 0
    assert any(m.startswith("rendering: frame 50/100") for m in s2)


def test_a_newer_request_of_the_same_page_supersedes_its_video(service, speech_wav, blocking_render):
    running, release = blocking_render
    req = Request(str(speech_wav), methods=["gesturelsm"], steps=1, size=256, exports=False, render=False)
    old, new = service.run(req), service.run(req)
    t1 = _render(service, old, "page", [])
    _until(lambda: old.job.folder.name in running)
    t2 = _render(service, new, "page", [])
    t1.join(10)
    assert isinstance(t1.out.get("error"), RenderCancelled)            # superseded: stopped without waiting
    release.set()
    t2.join(10)
    assert t2.out["result"].video is not None and service.renders.running == 0
