"""Fixtures for the aligner tests: synthetic speech with known word onsets, and the real BEAT2 takes."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from gesturelsm.align import tts
from _support import BEAT2

SR = 16_000
SENTENCE = ("the quick brown fox jumps over the lazy dog while seven happy children sing loudly "
            "in the garden behind our little house")


@dataclass
class Clip:
    audio: np.ndarray        # (N,) float32, 16 kHz
    words: list[str]
    onsets: np.ndarray       # (W,) seconds: where each word starts in `audio`


def _to_16k(y: np.ndarray, sr: int) -> np.ndarray:
    from gesturelsm.audio import resample

    return resample(y, sr, SR)


def make_clip(words: list[str], voice: str = "en-gb-x-rp", rate: int = 150, lead_s: float = 0.8,
              pauses: dict[int, float] | None = None, seed: int = 0) -> Clip:
    """Speak `words` with a voice the aligner does not use, insert silences before the words in `pauses`
    (index -> seconds), add `lead_s` of silence in front and a faint noise floor. The known onsets are
    eSpeak's own word events, moved by the inserted silence."""
    syn = tts.synthesize(words, (voice,), rate)[0]
    y = _to_16k(syn.audio, syn.sr)
    cuts = np.round(syn.starts * SR).astype(int)
    pieces, onsets, t = [np.zeros(int(lead_s * SR), np.float32)], [], lead_s
    for k in range(len(words)):
        extra = (pauses or {}).get(k, 0.0)
        pieces.append(np.zeros(int(extra * SR), np.float32))
        t += int(extra * SR) / SR
        onsets.append(t)
        end = cuts[k + 1] if k + 1 < len(words) else len(y)
        pieces.append(y[cuts[k]:end])
        t += (end - cuts[k]) / SR
    pieces.append(np.zeros(int(0.5 * SR), np.float32))
    audio = np.concatenate(pieces)
    audio = audio + 3e-4 * np.random.default_rng(seed).standard_normal(len(audio)).astype(np.float32)
    return Clip(audio.astype(np.float32), words, np.array(onsets))


@pytest.fixture(scope="session")
def clip_maker(espeak):
    """make_clip(words, voice=..., rate=..., lead_s=..., pauses={index: seconds}) -> Clip."""
    return make_clip


@pytest.fixture(scope="session")
def clip(espeak) -> Clip:
    return make_clip(SENTENCE.split(), pauses={8: 1.2, 14: 0.6})


@pytest.fixture(scope="session")
def beat2() -> Path:
    if not (BEAT2 / "textgrid").is_dir() or not (BEAT2 / "wave16k").is_dir():
        pytest.skip(f"real BEAT2 takes not found at {BEAT2} (../shared beside the repository)")
    return BEAT2
