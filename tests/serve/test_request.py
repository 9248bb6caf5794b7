"""A request's values (gesturelsm/serve/request.py): the timing table's rows are typed, their cells come in the
column order the page and the API show, and the generation time leaves out alignment, transcription and rendering.
Every figure is the time spent where it was spent: the one video's render time is the whole
request's (never the same share in every method's row), work done before the click is shown and marked, the whole
request's generation is never below one method's, an edit has its own row and never replaces the generation's
"Motion ready" figure, and no summary says "0.0 s"."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gesturelsm.serve.request import TIMING_COLUMNS, EditTiming, RenderJob, Result, TimingRow, timing_rows


def test_the_columns_the_page_and_the_api_show():
    """Each heading says its unit once (seconds, or a factor); the cells under it are plain numbers, no units."""
    assert TIMING_COLUMNS == ["method", "features (s)", "alignment (s)", "transcription (s)", "sampling (s)",
                              "decoding (s)", "rendering (s)", "generation (s)", "real-time factor (×)"]
    edit = EditTiming("GestureLSM, edit 1", {"sampling": 0.2}, 0.3, rendering=1.0)
    rows = timing_rows(TIMINGS, ground_truth=True, duration=10.0, render_s=6.0, edits=(edit,))
    for r in rows:
        label, *numbers = r.cells()
        assert isinstance(label, str) and all(v is None or type(v) is float for v in numbers), r.cells()


TIMINGS = {"gesturelsm": {"features": 0.1, "alignment": 2.0, "transcription": 3.0, "sampling": 0.3, "decoding": 0.1},
           "ddim": {"features": 0.1, "alignment": 2.0, "transcription": 3.0, "sampling": 0.9}}


def test_rows_per_method_ground_truth_and_the_whole_request():
    rows = timing_rows(TIMINGS, ground_truth=True, duration=10.0, render_s=6.0)
    assert all(isinstance(r, TimingRow) for r in rows)
    assert [r.method for r in rows] == ["GestureLSM", "DDIM", "Ground truth", "whole request, 10.0 s of speech"]
    ours = rows[0]
    assert ours.generation == pytest.approx(0.5)                  # features + sampling + decoding
    assert ours.real_time_factor == pytest.approx(20.0)           # 10 s of speech / 0.5 s
    assert ours.cells() == ["GestureLSM", 0.1, 2.0, 3.0, 0.3, 0.1, None, 0.5, 20.0]
    assert rows[1].decoding == 0.0 and rows[1].generation == pytest.approx(1.0)
    assert rows[2].cells()[1:] == [None] * 8                     # ground truth: a lookup, nothing generated
    whole = rows[-1]
    # the speech's stages once, every method's sampling and decoding, the video's render time
    assert whole.cells() == ["whole request, 10.0 s of speech", 0.1, 2.0, 3.0, 1.2, 0.1, 6.0, 1.4, 7.14]


def test_the_video_render_time_is_not_split_over_the_methods():
    rows = timing_rows(TIMINGS, ground_truth=False, duration=10.0, render_s=6.0)
    assert [r.rendering for r in rows] == [None, None, 6.0]        # one video: its own time, once
    before = timing_rows(TIMINGS, ground_truth=False, duration=10.0, render_s=None)
    assert [r.rendering for r in before] == [None, None, None]     # not rendered yet: no figure


def test_the_whole_request_generation_is_never_below_one_method():
    for timings in (TIMINGS, {"gesturelsm": {"features": 2.0, "sampling": 0.1}},
                    {"a": {"features": 0.5, "sampling": 3.0}, "b": {"features": 0.5, "sampling": 0.1}}):
        rows = timing_rows(timings, ground_truth=False, duration=10.0, render_s=None)
        assert rows[-1].generation >= max(r.generation for r in rows[:-1])


def test_work_done_before_the_click_is_shown_and_marked():
    rows = timing_rows(TIMINGS, ground_truth=False, duration=10.0, render_s=None, made_ahead=("gesturelsm",),
                       speech_ahead=True)
    assert rows[0].method == "GestureLSM (made ahead)" and rows[1].method == "DDIM"
    assert rows[0].transcription == 3.0 and rows[-1].transcription == 3.0       # its real time, not 0 s
    assert rows[0].generation == pytest.approx(0.5)
    assert "speech prepared at the upload" in rows[-1].method and "motion made ahead" in rows[-1].method


def test_an_edit_has_its_own_row_with_its_own_video():
    edit = EditTiming("GestureLSM, edit 1", {"encoding": 0.05, "sampling": 0.2, "decoding": 0.1, "merging": 0.01}, 0.4,
                      rendering=2.5)
    rows = timing_rows(TIMINGS, ground_truth=False, duration=10.0, render_s=6.0, edits=(edit,))
    assert [r.method for r in rows][:3] == ["GestureLSM", "DDIM", "GestureLSM, edit 1"]
    e = rows[2]
    assert (e.sampling, e.decoding, e.rendering, e.features, e.transcription) == (0.2, 0.1, 2.5, None, None)
    assert e.generation == pytest.approx(0.36) and rows[-1].rendering == 6.0    # the generation's video keeps its own


def _result(**kw) -> Result:
    job = RenderJob(Path("req"), (), ("GestureLSM",), (0.5,), np.zeros(16000, np.float32), 1.0, 256, 0.0)
    values = dict(video=None, rows=(), downloads=(), glb=None, text_mode="audio-only", warnings=(), ground_truth=None,
                  seconds=0.01, motion_seconds=0.01, timings={}, motions={}, transcript=None, job=job)
    return Result(**{**values, **kw})


def test_the_summary_never_says_zero_seconds_and_keeps_the_generation_after_an_edit():
    made = _result(made_ahead=("gesturelsm",), ahead_seconds=2.44)
    assert "0.0 s" not in made.summary
    assert ("Motion ready under 0.1 s after the click** (made ahead: 2.4 s of generation before the click)"
            in made.summary)
    plain = _result(motion_seconds=3.21)
    assert "**Motion ready in 3.2 s.**" in plain.summary and "Rendering the video (mp4)..." in plain.summary
    assert ("Rendering the video (mp4): frame 3/90, about 4 s left"
            in plain.summary_with("rendering: frame 3/90, about 4 s left"))
    edited = _result(motion_seconds=3.21, seconds=1.3, edits=("GestureLSM: upper 1.00-2.00 s, seed 1 (1.30 s)",),
                     edit_timings=(EditTiming("GestureLSM, edit 1", {"sampling": 1.0}, 1.3),))
    assert "**Motion ready in 3.2 s.**" in edited.summary                   # the generation's figure stays
    assert "**Edit made in 1.3 s.**" in edited.summary and "Rendering the edit's video" in edited.summary


def test_a_growing_result_says_what_is_ready_after_the_click():
    none_yet = _result(pending=("gesturelsm",), motion_seconds=0.0)
    assert "**Generating:** GestureLSM..." in none_yet.summary and "0.0 s" not in none_yet.summary
    one = _result(pending=("ddim",), motion_seconds=1.26, motions={"gesturelsm": object()})
    assert "**Ready 1.3 s after the click:** GestureLSM. **Generating:** DDIM..." in one.summary


def test_transcription_hidden_under_generation_is_a_row_of_its_own():
    """Words recognised while the first method was generated: the table says how much of the transcription ran
    hidden under generation, in a row of its own before the whole request's; it is not generation time."""
    from gesturelsm.pipelined import HIDDEN, WAITING

    timings = {"gesturelsm": {**TIMINGS["gesturelsm"], HIDDEN: 1.75, WAITING: 0.5}, "ddim": TIMINGS["ddim"]}
    rows = timing_rows(timings, ground_truth=False, duration=10.0, render_s=None)
    assert [r.method for r in rows] == ["GestureLSM", "DDIM", "of the transcription, hidden under generation",
                                        "whole request, 10.0 s of speech"]
    assert rows[2].cells() == ["of the transcription, hidden under generation", None, None, 1.75, None, None, None,
                               None, None]
    assert rows[0].generation == pytest.approx(0.5)
    assert "hidden" not in " ".join(r.method for r in timing_rows(TIMINGS, False, 10.0, None))
