"""Word timings: the types every part of the aligner returns, and one word per motion frame.

Times are seconds from the first audio sample. A word's interval is [start, end); silence has no Word.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Word:
    text: str
    start: float  # seconds
    end: float    # seconds, > start


@dataclass(frozen=True)
class AlignmentResult:
    """Words with times, how sure the aligner is (0..1), which method produced them, and a warning for the
    user when it fell back or the input looks wrong.

    method: "dtw" (transcript aligned to the audio), "even" (fallback: words spread over the voiced time by
    length), "textgrid" (read from a file), "audio-only" (no transcript: no words)."""

    words: list[Word]
    confidence: float
    method: str
    warning: str | None = None
    details: dict = field(default_factory=dict, compare=False)


def words_per_frame(words: list[Word], num_frames: int, fps: float = 30.0) -> list[str | None]:
    """Frame i -> the text of the word whose [start, end) contains t = i / fps, or None (silence).

    Where intervals overlap the later-starting word wins."""
    out: list[str | None] = [None] * num_frames
    if num_frames <= 0:
        return out
    for w in sorted(words, key=lambda w: w.start):
        i0 = max(0, int(np.ceil(w.start * fps - 1e-9)))
        i1 = min(num_frames, int(np.ceil(w.end * fps - 1e-9)))
        for i in range(i0, i1):
            out[i] = w.text
    return out
