"""A request's values (gesturelsm/serve/request.py): the timing table's rows are typed, their cells come in the
column order the page and the API show, and the generation time leaves out alignment, transcription and rendering."""
from __future__ import annotations

import pytest

from gesturelsm.serve.request import TIMING_COLUMNS, TimingRow, timing_rows


def test_the_columns_the_page_and_the_api_show():
    assert TIMING_COLUMNS == ["method", "features", "alignment", "transcription", "sampling", "decoding", "rendering",
                              "generation", "real-time factor"]


def test_rows_per_method_ground_truth_and_the_whole_request():
    timings = {"gesturelsm": {"features": 0.1, "alignment": 2.0, "transcription": 3.0, "sampling": 0.3,
                              "decoding": 0.1},
               "ddim": {"features": 0.1, "sampling": 0.9}}
    rows, shared = timing_rows(timings, ground_truth=True, duration=10.0, render_s=6.0, ready=12.0)
    assert all(isinstance(r, TimingRow) for r in rows)
    assert [r.method for r in rows] == ["GestureLSM", "DDIM", "Ground truth", "whole request, 10.0 s of speech"]
    ours = rows[0]
    assert ours.generation == pytest.approx(0.5)                  # features + sampling + decoding
    assert ours.real_time_factor == pytest.approx(20.0)           # 10 s of speech / 0.5 s
    assert ours.rendering == pytest.approx(2.0) and shared["gesturelsm"]["rendering"] == pytest.approx(2.0)
    assert ours.cells() == ["GestureLSM", 0.1, 2.0, 3.0, 0.3, 0.1, 2.0, 0.5, 20.0]
    assert rows[1].alignment == 0.0 and rows[1].generation == pytest.approx(1.0)
    assert rows[2].real_time_factor is None and rows[2].rendering == pytest.approx(2.0)
    whole = rows[-1]
    assert whole.cells() == ["whole request, 10.0 s of speech", None, None, None, None, None, 6.0, 12.0, 0.83]
