"""english_pieces (gesturelsm/asr/transcribe.py): the first window recognised and timed first, then each next window
recognised on its own thread while the one before is timed; pieces in order and the same as one after the other."""
from __future__ import annotations

import threading

import numpy as np
import pytest

from gesturelsm.align import Word
import importlib

from gesturelsm.asr.recognition_windows import recognition_cuts

tr = importlib.import_module("gesturelsm.asr.transcribe")       # the module (the package exports its function)

SR = 16_000


def _speech(seconds: float = 70.0) -> np.ndarray:
    t = np.arange(int(seconds * SR)) / SR
    return (0.1 * np.sin(2 * np.pi * 150 * t) * (np.sin(2 * np.pi * 0.7 * t) > -0.6)).astype(np.float32)


class Stand:
    """Recognition and timing stand-ins that log what runs when, per window (by its first sample)."""

    def __init__(self, y: np.ndarray):
        self.starts = recognition_cuts(y)[:-1]
        self.log: list[str] = []
        self.timing = {k: threading.Event() for k in range(len(self.starts))}
        self.recognised = {k: threading.Event() for k in range(len(self.starts))}
        self.lock = threading.Lock()

    def window(self, chunk: np.ndarray, y: np.ndarray) -> int:
        return next(k for k, a in enumerate(self.starts) if np.shares_memory(chunk, y[a:a + 1]))

    def recognized(self, y):
        def fake(chunk, beam_size, model, language):
            k = self.window(chunk, y)
            if k >= 2:      # window k is recognised only while window k - 1 is being timed: they overlap
                assert self.timing[k - 1].wait(10), f"window {k - 1} was not being timed while {k} was recognised"
            with self.lock:
                self.log.append(f"recognise {k}")
            self.recognised[k].set()
            return [Word(f"w{k}", 0.5, 0.9)], -0.2, 4, {"max_no_speech_probability": 0.0}
        return fake

    def timed(self, y):
        def fake(chunk, words, heard, timing):
            k = self.window(chunk, y)
            self.timing[k].set()
            with self.lock:
                self.log.append(f"time {k}")
            if 1 <= k < len(self.starts) - 1:      # the timing ends once the next window is recognised
                assert self.recognised[k + 1].wait(10), f"window {k + 1} was not recognised while {k} was timed"
            return words, "dtw", []
        return fake


def test_the_next_window_is_recognised_while_the_one_before_is_timed_and_pieces_come_in_order(monkeypatch):
    y = _speech()
    stand = Stand(y)
    assert len(stand.starts) >= 3
    monkeypatch.setattr(tr, "_recognized", stand.recognized(y))
    monkeypatch.setattr(tr, "_timed", stand.timed(y))
    pieces = list(tr.english_pieces(y))
    assert [p.heard for p in pieces] == [f"w{k}" for k in range(len(stand.starts))]
    assert stand.log[:3] == ["recognise 0", "time 0", "recognise 1"]     # the first window before anything else
    assert [p.final_until for p in pieces[:-1]] == [b / SR for b in recognition_cuts(y)[1:-1]]
    assert pieces[-1].final_until == np.inf
    assert pieces[1].words[0].start == pytest.approx(stand.starts[1] / SR + 0.5)


def test_the_next_window_is_recognised_while_the_caller_handles_the_first_piece(monkeypatch):
    """What the caller does with window 0's piece (the pipeline makes its text features, which may wait for the text
    encoder to load) does not hold up the recognition of window 1."""
    y = _speech()
    second = threading.Event()
    starts = recognition_cuts(y)[:-1]

    def fake(chunk, beam_size, model, language):
        if np.shares_memory(chunk, y[starts[1]:starts[1] + 1]):
            second.set()
        return [Word("w", 0.5, 0.9)], -0.2, 4, {"max_no_speech_probability": 0.0}
    monkeypatch.setattr(tr, "_recognized", fake)
    monkeypatch.setattr(tr, "_timed", lambda chunk, words, heard, timing: (words, "dtw", []))
    got = tr.english_pieces(y)
    first = next(got)                                  # the caller holds the first piece ...
    assert second.wait(30), "window 1 was recognised only once the caller was done with window 0's piece"
    assert first.final_until == starts[1] / SR
    assert [p.heard for p in got] == ["w"] * (len(starts) - 1)


def test_a_recognition_error_on_the_thread_is_raised_where_the_pieces_are_read(monkeypatch):
    y = _speech()
    starts = recognition_cuts(y)[:-1]

    def fake(chunk, beam_size, model, language):
        if np.shares_memory(chunk, y[starts[2]:starts[2] + 1]):
            raise RuntimeError("the recogniser broke on window 2")
        return [], 0.0, 0, {"max_no_speech_probability": 1.0}
    monkeypatch.setattr(tr, "_recognized", fake)
    got = tr.english_pieces(y)
    next(got), next(got)
    with pytest.raises(RuntimeError, match="window 2"):
        next(got)


def test_pieces_no_longer_read_stop_the_recognition_thread(monkeypatch):
    y = _speech()
    calls = []

    def fake(chunk, beam_size, model, language):
        calls.append(1)
        return [], 0.0, 0, {"max_no_speech_probability": 1.0}
    monkeypatch.setattr(tr, "_recognized", fake)
    got = tr.english_pieces(y)
    next(got), next(got)
    got.close()
    for t in threading.enumerate():
        if t.name == "gesturelsm-recognise":
            t.join(10)
            assert not t.is_alive()
    assert len(calls) <= 3                  # windows 0 and 1, at most one more recognised ahead; not all


def test_real_speech_gives_the_pieces_of_recognising_and_timing_one_window_after_the_other(recognizer, beat2):
    from gesturelsm.audio import load_audio

    y = load_audio(beat2 / "wave16k" / "2_scott_0_2_2.wav")[: 40 * SR]
    cuts = recognition_cuts(y)
    spans = list(zip(cuts, cuts[1:]))
    one_by_one = [tr._piece(y, a, b, *tr._recognized(y[a:b], tr.BEAM_SIZE, None, "en"), "auto", k == len(spans) - 1)
                  for k, (a, b) in enumerate(spans)]
    assert len(spans) >= 2 and list(tr.english_pieces(y)) == one_by_one
