"""gesturelsm.asr.transcribe: recognised words in order with sensible times; honest rejection otherwise."""
from __future__ import annotations


import numpy as np
import pytest

from gesturelsm.align import read_words
from gesturelsm.asr import transcribe
from gesturelsm.asr.transcribe import AUDIO_ONLY_NOTE
from gesturelsm.audio import load_audio

from _asr_support import ENGLISH, SR
from _asr_support import matched as _matched


def test_synthetic_english_comes_back_in_order_with_increasing_times(recognizer, english):
    tr = transcribe(english)
    ref = ENGLISH.split()
    got = [w.text for w in tr.words]
    assert tr.accepted and tr.language == "en" and tr.timing_method == "dtw"
    assert _matched(got, ref) >= len(ref) - 2                         # at most two words misheard, order kept
    starts = np.array([w.start for w in tr.words])
    assert np.all(np.diff(starts) > 0) and all(w.end > w.start for w in tr.words)
    assert 0.3 < starts[0] < 1.0 and tr.words[-1].end <= len(english) / SR  # speech starts after the 0.5 s lead
    assert _plain(" ".join(got)) == _plain(tr.text)                   # the words are the text (punctuation aside)


def test_whisper_and_aligner_timings_agree_roughly(recognizer, english):
    a, b = transcribe(english, timing="whisper"), transcribe(english, timing="dtw")
    assert a.timing_method == "whisper" and b.timing_method == "dtw"
    assert _plain(" ".join(w.text for w in a.words)) == _plain(" ".join(w.text for w in b.words))   # same words
    diff = np.abs([x.start - y.start for x, y in zip(a.words, b.words)])
    assert np.median(diff) < 0.15 and not np.allclose(diff, 0)


def test_real_speech_finds_the_mfa_words(recognizer, beat2):
    y = load_audio(beat2 / "wave16k" / "2_scott_0_2_2.wav")[: 20 * SR]
    ref = [w for w in read_words(beat2 / "textgrid" / "2_scott_0_2_2.TextGrid") if w.end < 19.5]
    tr = transcribe(y)
    assert tr.accepted and _matched([w.text for w in tr.words], [w.text for w in ref]) >= 0.9 * len(ref)


def _music(seconds: float = 4.0) -> np.ndarray:
    t = np.arange(int(seconds * SR)) / SR
    chord = sum(np.sin(2 * np.pi * f * h * t + k) / h for k, f in enumerate((220, 277, 330, 440)) for h in (1, 2, 3))
    beat = (np.sin(2 * np.pi * 2 * t) > 0.95) * np.random.default_rng(1).normal(size=len(t))
    return (0.03 * chord + 0.05 * beat).astype(np.float32)


@pytest.mark.parametrize("name", ["silence", "white noise", "music"])
def test_no_speech_gives_no_words_and_a_message(recognizer, name):
    y = {"silence": np.zeros(3 * SR, np.float32),
         "white noise": (0.05 * np.random.default_rng(0).standard_normal(3 * SR)).astype(np.float32),
         "music": _music()}[name]
    tr = transcribe(y)
    assert not tr.accepted and tr.words == [] and tr.text == "" and tr.language == "unknown"
    assert len(tr.warnings) == 1 and tr.warnings[0].endswith(AUDIO_ONLY_NOTE)


def test_german_speech_is_rejected_not_fed_as_english(recognizer, german):
    tr = transcribe(german, language="en")                              # English only: the multilingual model unused
    assert not tr.accepted and tr.words == [] and tr.timing_method == "none"
    assert "may not be English" in tr.warnings[0] and tr.heard                 # it says what it heard
    assert tr.details["avg_logprob"] < -0.6


def test_bad_timing_option_is_refused():
    with pytest.raises(ValueError, match="timing must be one of"):
        transcribe(np.zeros(SR, np.float32), timing="mfa")


def _plain(text: str) -> list[str]:
    """Lower-case words without punctuation (Whisper may or may not end a sentence with a full stop)."""
    import re

    return re.findall(r"[a-z0-9']+", text.lower())


def test_whisper_word_times_are_made_sequential_and_write_as_a_textgrid(tmp_path):
    """Whisper's fast words: zero length, the same start as the neighbour, or starting inside it. They must come out
    ordered, non-overlapping and of positive length, so the TextGrid writer accepts them (it refused before)."""
    from gesturelsm.align import TextGridError, Word, read_words, write_textgrid
    from gesturelsm.asr.transcribe import sequential

    raw = [Word("good", 4.50, 4.92), Word("morning", 4.92, 4.92), Word("to", 4.92, 5.10), Word("you", 5.00, 5.40),
           Word("all", 5.60, 5.90)]
    got = sequential(raw)
    assert [w.text for w in got] == [w.text for w in raw]
    for a, b in zip(got, got[1:]):
        assert a.end <= b.start
    assert all(w.end - w.start >= 0.01 - 1e-9 for w in got)
    assert got[0] == raw[0] and got[-1] == raw[-1]                 # untouched where Whisper was already fine
    assert got[1].start == 4.92 and got[2].start >= got[1].end and got[3].start >= 5.10
    with pytest.raises(TextGridError, match="no duration"):
        write_textgrid(tmp_path / "raw.TextGrid", raw)
    path = tmp_path / "w.TextGrid"
    write_textgrid(path, got)
    back = read_words(path)
    assert [w.text for w in back] == [w.text for w in raw]
