"""gesturelsm.asr.transcribe.recognize: one greedy pass, Whisper's temperature fallback only where some windows loop,
audio whose every window loops rejected at once. A fake recogniser stands in for Whisper (what it is asked, what it
answers); the real one is checked on synthetic chords."""
from __future__ import annotations

import importlib
from types import SimpleNamespace

import numpy as np
import pytest

from gesturelsm.asr.transcribe import AUDIO_ONLY_NOTE, FALLBACK_TEMPERATURES, LOOP_RATIO, recognize, transcribe
from gesturelsm.asr.recognition_windows import recognition_cuts

from _asr_support import SR

tmod = importlib.import_module("gesturelsm.asr.transcribe")   # the module (the package exports its function)


def _segment(text: str, ratio: float, start: float = 0.0) -> SimpleNamespace:
    words = [SimpleNamespace(word=f" {w}", start=start + 0.3 * i, end=start + 0.3 * i + 0.2, probability=0.9)
             for i, w in enumerate(text.split())]
    return SimpleNamespace(text=text, tokens=list(range(len(words) + 1)), avg_logprob=-0.2, compression_ratio=ratio,
                           no_speech_prob=0.01, words=words)


class FakeWhisper:
    """Answers each temperature setting with the given segments and records what it was asked."""

    def __init__(self, greedy: list, fallback: list | None = None):
        self.greedy, self.fallback, self.asked = greedy, fallback, []

    def transcribe(self, audio, **kw):
        self.asked.append(kw["temperature"])
        return iter(self.greedy if kw["temperature"] == 0.0 else self.fallback), None


@pytest.fixture
def fake(monkeypatch):
    def install(greedy, fallback=None) -> FakeWhisper:
        model = FakeWhisper(greedy, fallback)
        monkeypatch.setattr(tmod, "load_model", lambda: model)
        return model
    return install


AUDIO = np.full(2 * SR, 0.1, np.float32)


def test_greedy_words_are_kept_without_a_second_pass(fake):
    model = fake([_segment("hello there", 1.3), _segment("general idea", 1.1, 2.0)])
    words, avg, details = recognize(AUDIO)
    assert model.asked == [0.0]
    assert [w.text for w in words] == ["hello", "there", "general", "idea"] and avg == pytest.approx(-0.2)
    assert "repeated_phrase" not in details


def test_audio_whose_every_window_loops_is_rejected_after_one_pass(fake):
    model = fake([_segment("so I'm gonna so I'm gonna so I'm gonna", LOOP_RATIO + 8)] * 2)
    words, avg, details = recognize(AUDIO)
    assert model.asked == [0.0] and words == [] and avg == -np.inf and details["repeated_phrase"]
    tr = transcribe(AUDIO, timing="whisper")
    assert not tr.accepted and tr.words == [] and "one phrase over and over" in tr.warnings[0] and tr.heard
    assert "so I'm gonna" in tr.warnings[0] and tr.warnings[0].endswith(AUDIO_ONLY_NOTE)


def test_a_loop_in_some_windows_decodes_again_with_the_fallback(fake):
    model = fake([_segment("real words here", 1.4), _segment("la la la la la la la la", LOOP_RATIO + 1, 2.0)],
                 fallback=[_segment("real words here", 1.4), _segment("and then more", 1.2, 2.0)])
    words, _, _ = recognize(AUDIO)
    assert model.asked == [0.0, list(FALLBACK_TEMPERATURES)]
    assert [w.text for w in words] == ["real", "words", "here", "and", "then", "more"]


def test_a_window_ending_on_punctuation_alone_is_not_a_loop_and_adds_no_words(fake):
    """Whisper gives a short-context window's last second as " ." with the window's compression ratio, over the loop
    bar: there are no words in it to recover, so one greedy pass stands and the dot is no word."""
    model = fake([_segment("real words here", 1.4), _segment(" .", LOOP_RATIO + 3.5, 2.0)],
                 fallback=[_segment("real words here", 1.4), _segment("Okay.", 1.2, 2.0)])
    words, avg, details = recognize(AUDIO)
    assert model.asked == [0.0]
    assert [w.text for w in words] == ["real", "words", "here"] and avg == pytest.approx(-0.2)
    assert details["word_probabilities"] == [0.9] * 3


def test_punctuation_alone_everywhere_is_no_speech_not_a_repeated_phrase(fake):
    model = fake([_segment("...", LOOP_RATIO + 3), _segment(" .", LOOP_RATIO + 3, 2.0)])
    words, avg, details = recognize(AUDIO)
    assert model.asked == [0.0] and words == [] and avg == -np.inf and "repeated_phrase" not in details
    tr = transcribe(AUDIO, timing="whisper")
    assert not tr.accepted and "No speech was recognised" in tr.warnings[0] and tr.details["no_words"]


def test_chords_are_rejected_by_the_real_recogniser_in_one_pass(recognizer, monkeypatch):
    """30 s of a steady chord: Whisper's greedy pass writes one phrase over and over (the CTranslate2 kernels of some
    CPUs give no segment at all); either way it is rejected without the five sampling passes of the fallback: one
    greedy pass per recognition window (asr/recognition_windows.py)."""
    passes = []
    decode = tmod._decode
    monkeypatch.setattr(tmod, "_decode", lambda *a: passes.append(a[2]) or decode(*a))
    t = np.arange(30 * SR) / SR
    chords = sum(0.1 * np.sin(2 * np.pi * f * t * (1 + 0.01 * np.sin(np.pi * t))) for f in (261.6, 329.6, 392.0, 523.3))
    tr = transcribe(chords.astype(np.float32), language="en")          # the English model alone
    assert passes == [0.0] * (len(recognition_cuts(chords)) - 1)
    assert not tr.accepted
    assert (("one phrase over and over" in tr.warnings[0] and tr.details["repeated_phrase"])
            or ("No speech was recognised" in tr.warnings[0] and tr.details["no_words"])
            or ("unsure of what it heard" in tr.warnings[0] and tr.details["not_english"]))   # a window's phrase
