"""One word per motion frame, and the onset-error metric."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.align import Word, words_per_frame
from gesturelsm.align.metrics import onset_errors_ms, onset_stats


def test_each_frame_gets_the_word_whose_interval_contains_it():
    words = [Word("hi", 0.1, 0.2), Word("there", 0.2, 0.5), Word("you", 0.9, 1.0)]
    frames = words_per_frame(words, 32, fps=30)
    t = np.arange(32) / 30
    expected = [next((w.text for w in words if w.start <= ti < w.end), None) for ti in t]
    assert frames == expected
    assert frames[3] == "hi" and frames[6] == "there" and frames[15] is None and frames[27] == "you"
    assert frames[30] is None                      # 1.0 s: the interval end is exclusive


def test_frames_outside_the_words_are_silence_and_lengths_match():
    assert words_per_frame([], 5) == [None] * 5
    assert words_per_frame([Word("late", 10.0, 11.0)], 3) == [None, None, None]
    assert words_per_frame([Word("a", 0.0, 1.0)], 0) == []
    assert words_per_frame([Word("a", 0.0, 0.1)], 4, fps=20) == ["a", "a", None, None]


def test_onset_errors_pair_words_by_spoken_form_and_skip_unmatched():
    ref = [Word("I", 0.0, 0.2), Word("have", 0.2, 0.5), Word("five", 0.5, 0.9), Word("cats", 0.9, 1.3)]
    pred = [Word("I", 0.05, 0.2), Word("have", 0.35, 0.5), Word("really", 0.4, 0.5), Word("5", 0.62, 0.9),
            Word("Cats", 0.9, 1.3)]
    errs = onset_errors_ms(pred, ref)
    np.testing.assert_allclose(errs, [50, 150, 120, 0], atol=1e-6)
    s = onset_stats(errs)
    assert s.n == 4 and s.mean_ms == pytest.approx(80) and s.within_100ms == 0.5
