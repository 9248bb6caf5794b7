"""A tab closed in the middle of Generate, an edit or a sweep (Gradio's unload, `_Handlers.session_ended`): the
work stops at its next step (window or motion) instead of running on for nobody, the handler ends without output
or error, nothing of it stays registered, and another tab's request, under way at the same moment, finishes with
its motion (gesturelsm/webapp/closing.py). That unload fires when a tab closes is Gradio's (its heartbeat; the
browser test tests/serve/test_render_queue_browser.py closes a tab mid-video); here it is called as Gradio calls it."""
from __future__ import annotations

from types import SimpleNamespace

import gradio as gr
import pytest
import soundfile as sf

from _support import quiet, speech_like
from gesturelsm.webapp.closing import PageClosed, PageWork
from gesturelsm.webapp.edit_section import EditHandlers
from gesturelsm.webapp.sweep_tab import SweepHandlers
from gesturelsm.webapp.ui import _Handlers, build_demo

A, B = SimpleNamespace(session_hash="tab-a"), SimpleNamespace(session_hash="tab-b")


def inputs(wav, seed: int) -> tuple:
    return (str(wav), "", None, ["gesturelsm"], 1, 2.0, seed, 2, False, "off", 256, False, True, "auto")


@pytest.fixture(scope="module")
def long_wav(tmp_path_factory):
    """8 s of speech: several windows, so that a step follows the one during which the tab closes."""
    path = tmp_path_factory.mktemp("closed_tab") / "speech.wav"
    sf.write(path, speech_like(8.0, seed=3), 16000)
    return path


class Closer:
    """A progress callback that closes tab A (as Gradio's unload does) at the first message matching `when`, and
    records every message and whether any came after the close."""

    def __init__(self, h, when):
        self.h, self.when, self.closed_at, self.seen = h, when, None, []

    def __call__(self, f, desc=""):
        self.seen.append(desc)
        if self.closed_at is None and self.when(desc):
            self.closed_at = len(self.seen)
            self.h.session_ended(A)

    @property
    def after(self) -> list[str]:
        return self.seen[self.closed_at:] if self.closed_at is not None else []


def test_the_page_has_one_unload_for_its_videos_and_its_running_work(service):
    demo = build_demo(service)
    fns = demo.blocks.fns
    unloads = [f for f in (fns.values() if isinstance(fns, dict) else fns)
               if any(t[1] == "unload" for t in f.targets)]
    assert [f.fn.__name__ for f in unloads] == ["session_ended"]      # one unload: videos and running work


def test_a_tab_closed_mid_generate_stops_its_generation_not_another_tabs(service, long_wav):
    h = _Handlers(service)
    other = h.show_motion(*inputs(long_wav, 1), request=B, progress=quiet)
    assert not next(other)[3].motions                                 # tab B's request is under way
    close = Closer(h, lambda m: "window" in m)
    shown = list(h.show_motion(*inputs(long_wav, 2), request=A, progress=close))
    assert close.closed_at is not None, close.seen
    assert close.after == []                                         # nothing was made after the close
    assert all(not out[3].motions for out in shown)                  # no motion for a closed tab
    rest = list(other)
    assert rest[-1][3].motions and "gesturelsm" in rest[-1][3].motions    # tab B: its motion
    assert h.pages.pages == 0                                        # nothing of either stays registered
    assert service.ahead._requests == 0                              # the generation's count is released


def test_a_tab_closed_mid_edit_stops_the_edit(service, long_wav):
    h = _Handlers(service)
    e = EditHandlers(h)
    out = list(h.show_motion(*inputs(long_wav, 1), request=A, progress=quiet))[-1][3]
    close = Closer(h, lambda m: "window" in m)
    answer = e.run(out, "gesturelsm", 1.0, 6.0, ["upper"], 4, request=A, progress=close)
    assert close.closed_at is not None and close.after == []
    assert all(isinstance(x, type(gr.skip())) for x in answer)       # nothing sent to the closed page
    assert h.pages.pages == 0
    new = e.run(out, "gesturelsm", 1.0, 6.0, ["upper"], 4, request=B, progress=quiet)[3]    # another tab edits
    assert new.motions["gesturelsm"].num_frames == out.motions["gesturelsm"].num_frames


def test_a_tab_closed_mid_sweep_stops_before_its_next_motion(service, long_wav):
    h = _Handlers(service)
    sweep = SweepHandlers(service, pages=h.pages)
    before = set(service.workdir.glob("req-*"))
    close = Closer(h, lambda m: m.startswith("1/3 motions"))
    answer = sweep.run(str(long_wav), ["gesturelsm"], "1 2 3", "0", 1, "bc", "", False, request=A, progress=close)
    assert close.closed_at is not None
    assert not any(m.startswith(("2/3", "3/3")) for m in close.seen)
    assert all(isinstance(x, type(gr.skip())) for x in answer)
    assert set(service.workdir.glob("req-*")) == before              # nothing written
    assert h.pages.pages == 0 and sweep._stop == {}                  # no flag kept for the closed tab


def test_page_work_flags_are_per_page_and_go_with_the_work():
    pages = PageWork()
    with pages.running(A) as a1, pages.running(A) as a2, pages.running(B) as b, pages.running(None) as anon:
        assert pages.pages == 2
        assert pages.close(A) == 2 and a1.is_set() and a2.is_set() and not b.is_set() and not anon.is_set()
        report = PageWork.checked(quiet, a1)
        with pytest.raises(PageClosed):
            report(0.5, "window 2/3")
        PageWork.checked(quiet, b)(0.5, "window 2/3")
        assert pages.close(None) == 0 and not anon.is_set()
    assert pages.pages == 0 and pages.close(B) == 0
