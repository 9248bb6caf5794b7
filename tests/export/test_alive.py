"""export/alive.py with a motion's words: the mouth shut in the pauses, blinks at word borders and in pauses; and
without words, the face of the words-free rule, bit for bit."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.export import arkit_face
from gesturelsm.export.alive import (BORDER_S, JAW_FULL, PAUSE_S, Blinker, alive_face_weights, blink_free, mid_word,
                                     pause_gate)
from gesturelsm.motion import MotionSequence
from gesturelsm.motion.skeleton import JOINT_INDEX

FPS = 30
# two phrases of three touching words, a 1 s pause between them, a short (0.2 s) gap inside the second
WORDS = (("so", 0.2, 0.5), ("we", 0.5, 0.8), ("went", 0.8, 1.2),
         ("home", 2.2, 2.6), ("and", 2.8, 3.1), ("slept", 3.1, 3.6))


def _speaking(T: int, words=()) -> MotionSequence:
    """T frames with the jaw half open and moving (the face of speech) in every frame, `words` attached."""
    poses = np.zeros((T, 165))
    j = 3 * JOINT_INDEX["jaw"]
    poses[:, j] = JAW_FULL * (0.45 + 0.25 * np.sin(np.arange(T) * 0.7))
    return MotionSequence(poses, np.tile([0.0, 1.3, 0.0], (T, 1)), np.zeros((T, 100)), fps=FPS, words=words)


def _onsets(w: np.ndarray) -> np.ndarray:
    return np.flatnonzero((w[1:] >= 0.5) & (w[:-1] < 0.5)) + 1


def test_pause_gate_is_one_in_words_and_short_gaps_and_zero_mid_pause():
    T = 4 * FPS
    gate = pause_gate(WORDS, T, FPS)
    t = np.arange(T) / FPS
    for _, a, b in WORDS:
        assert np.all(gate[(t >= a) & (t <= b)] == 1.0)                 # never inside a word
    assert np.all(gate[(t > 2.6) & (t < 2.8)] == 1.0)                   # a 0.2 s gap is no pause
    assert np.all(gate[(t >= 1.4) & (t <= 2.0)] == 0.0)                 # shut in the pause
    assert np.all(gate[t <= 0.05] == 0.0) and np.all(gate[t >= 3.8] == 0.0)     # before the first, after the last
    assert np.abs(np.diff(gate)).max() < 0.5                            # eased, no step
    assert pause_gate((), T, FPS) is None and blink_free((), T, FPS) is None


def test_jaw_shut_in_the_pause_and_unchanged_inside_words(body):
    T = 4 * FPS
    plain = arkit_face(_speaking(T), body, blinks=False)
    worded = arkit_face(_speaking(T, WORDS), body, blinks=False)
    t = np.arange(T) / FPS
    jaw, jaw0 = worded.weight("JawOpen"), plain.weight("JawOpen")
    assert np.median(jaw0[(t >= 1.4) & (t <= 2.0)]) > 0.3               # the motion's jaw is open in the pause
    assert np.all(jaw[(t >= 1.4) & (t <= 2.0)] == 0.0)                  # the export's is shut
    assert np.all(worded.weight("MouthClose")[(t >= 1.4) & (t <= 2.0)] == 0.0)
    inside = np.zeros(T, bool)
    for _, a, b in WORDS:
        inside |= (t >= a) & (t <= b)
    np.testing.assert_array_equal(jaw[inside], jaw0[inside])           # words untouched
    np.testing.assert_array_equal(worded.head, plain.head)
    visemes = alive_face_weights(body, _speaking(T, WORDS))
    visemes0 = alive_face_weights(body, _speaking(T))
    assert all(np.all(visemes[v][(t >= 1.4) & (t <= 2.0)] == 0.0) for v in ("aa", "ih", "ou", "ee", "oh"))
    np.testing.assert_array_equal(visemes["aa"][inside], visemes0["aa"][inside])


def _speech(seconds: float, seed: int = 1):
    """Words of 0.15-0.5 s, mostly touching, with a pause of 0.5-1.2 s every 4-9 words: ~85 % of the time."""
    rng = np.random.default_rng(seed)
    words, t, n = [], 0.3, 0
    while t < seconds - 1.0:
        d = rng.uniform(0.15, 0.5)
        words.append((f"w{n}", t, t + d))
        t += d + (rng.uniform(0.5, 1.2) if rng.random() < 1 / 6 else 0.0)
        n += 1
    return tuple(words)


def test_blinks_mostly_at_borders_and_in_pauses_when_words_are_known():
    seconds = 600
    T = seconds * FPS
    words = _speech(seconds)
    mouth = np.full(T, 0.4)                                            # the mouth never closes: only words can tell
    placed = Blinker(FPS, seed=0).next(mouth, blink_free(words, T, FPS))
    blind = Blinker(FPS, seed=0).next(mouth)
    for w in (placed, blind):
        rate = len(_onsets(w)) / seconds * 60
        assert 6 <= rate <= 30
    moments = lambda w: (_onsets(w) - 0.5) / FPS                       # noqa: E731  the half-shut moment
    share, share0 = mid_word(words, moments(placed)).mean(), mid_word(words, moments(blind)).mean()
    assert share0 > 0.25                                               # waiting for a closed mouth does nothing here
    assert 0.0 < share < share0 / 2                                    # some mid-word blinks, but few
    gaps = np.diff(_onsets(placed)) / FPS
    assert gaps.std() > 0.5                                            # irregular


def test_blink_border_zone_counts_word_borders():
    words = (("a", 0.0, 1.0), ("b", 1.0, 2.0))
    assert list(mid_word(words, [0.5, 1.0 - BORDER_S / 2, 1.0 + BORDER_S / 2, 1.5])) == [True, False, False, True]
    free = blink_free(words, 2 * FPS, FPS)
    assert free[int(1.0 * FPS) - 1] and not free[int(0.5 * FPS)]
    assert PAUSE_S < 0.5


def test_without_words_the_blinks_are_todays_bit_for_bit():
    """Golden values of the words-free rule: the same seed, the same mouth, the same blinks."""
    t = np.arange(1800) / FPS
    mouth = 0.3 * (np.sin(2 * np.pi * t * 1.7) > 0)
    w = Blinker(FPS, seed=0).next(mouth)
    assert _onsets(w).tolist() == [82, 218, 338, 415, 523, 586, 682, 779, 899, 974, 1088, 1184, 1304, 1449, 1652,
                                   1776]
    assert float(w.sum()) == pytest.approx(81.643576, abs=1e-6)


def test_without_words_the_face_is_the_measured_one(body):
    T = 4 * FPS
    seq = _speaking(T)
    face = arkit_face(seq, body)
    again = arkit_face(_speaking(T), body, blinker=Blinker(FPS, 0))
    np.testing.assert_array_equal(face.weights, again.weights)
    assert face.weight("JawOpen").min() > 0.1                          # no pause closes a mouth without words


def test_real_take_with_its_textgrid_words_shuts_the_mouth_in_pauses(beat2_root, real_motion, body):
    """The speaker's take (its first 30 s) with its TextGrid's words: JawOpen near 0 in pauses of 0.5 s or more,
    the words' frames as without words, speech still reaching a face capture's range, few blinks mid-word."""
    from dataclasses import replace

    from gesturelsm.align.textgrid import read_words

    seconds = 30.0
    T = int(seconds * real_motion.fps)
    words = tuple((w.text, w.start, w.end) for w in read_words(beat2_root / "textgrid" / "2_scott_0_1_1.TextGrid")
                  if w.text.strip() and w.start < seconds)
    words = tuple((w, a, min(b, seconds)) for w, a, b in words)
    seq = real_motion.slice(0, T)
    face = arkit_face(replace(seq, words=words), body)
    plain = arkit_face(seq, body)
    t = np.arange(T) / real_motion.fps
    inside = np.zeros(T, bool)
    for _, a, b in words:
        inside |= (t >= a) & (t < b)
    spans = sorted((a, b) for _, a, b in words)
    pause = np.zeros(T, bool)
    for (_, end), (start, _) in zip(spans[:-1], spans[1:]):
        if start - end >= 0.5:
            pause |= (t >= end) & (t < start)
    assert pause.sum() > 15 and np.median(plain.weight("JawOpen")[pause]) > 0.1      # open in pauses without words
    jaw = face.weight("JawOpen")
    assert np.median(jaw[pause]) <= 0.05
    np.testing.assert_array_equal(jaw[inside], plain.weight("JawOpen")[inside])
    assert np.percentile(jaw, 95) >= 0.25
    blinks = (_onsets(face.weight("EyeBlinkLeft")) - 0.5) / real_motion.fps
    assert 3 <= len(blinks) <= 15                                      # 6-30 a minute
    assert mid_word(words, blinks).mean() < 0.5
