"""The English model's short context (gesturelsm/asr/model.py): which pieces it encodes with 15 s instead of 30 s, and
that the first recognition window of real speech, read that way, finds the words MFA found there."""
from __future__ import annotations

import numpy as np
import pytest

from _asr_support import matched
from gesturelsm.asr import model
from gesturelsm.asr.model import FULL_FRAMES, PAD_FRAMES, SHORT_FRAMES, context_frames


def _padded(spoken: int) -> np.ndarray:
    x = np.zeros((80, FULL_FRAMES), np.float32)
    x[:, :spoken] = np.random.default_rng(spoken).normal(size=(80, spoken))
    return x


@pytest.mark.parametrize("spoken, frames", [(800, SHORT_FRAMES), (SHORT_FRAMES - PAD_FRAMES, SHORT_FRAMES),
                                            (SHORT_FRAMES - PAD_FRAMES + 1, FULL_FRAMES), (2400, FULL_FRAMES),
                                            (FULL_FRAMES, FULL_FRAMES)])
def test_a_piece_is_encoded_short_only_when_its_speech_ends_a_second_before_the_short_context(spoken, frames):
    assert context_frames(_padded(spoken)) == frames
    assert context_frames(_padded(spoken)[None]) == frames          # batched (1, 80, 3000) as faster-whisper sends


def test_a_frame_of_zeros_inside_the_speech_does_not_end_it():
    x = _padded(2000)
    x[:, 1200:1300] = 0.0                                           # digital silence inside: the speech goes on
    assert context_frames(x) == FULL_FRAMES


def test_the_first_window_of_real_speech_is_read_short_and_finds_the_mfa_words(recognizer, beat2, monkeypatch):
    from gesturelsm.align import read_words
    from gesturelsm.asr.transcribe import english_pieces
    from gesturelsm.audio import load_audio

    y = load_audio(beat2 / "wave16k" / "2_scott_0_1_1.wav")[: 30 * 16000]
    encoded = []
    m = model.load_model()
    encode = type(m).__mro__[1].encode                             # faster-whisper's own, under the short context
    monkeypatch.setattr(type(m).__mro__[1], "encode", lambda self, f: encoded.append(f.shape[-1]) or encode(self, f))
    first = next(english_pieces(y))
    assert encoded[0] == SHORT_FRAMES                               # the first window (~9.5 s): the short context
    ref = [w for w in read_words(beat2 / "textgrid" / "2_scott_0_1_1.TextGrid") if w.end <= first.final_until]
    assert matched([w.text for w in first.words], [w.text for w in ref]) >= 0.85 * len(ref)
