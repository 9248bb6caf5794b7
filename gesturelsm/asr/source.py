"""Which transcript a request uses: typed transcript > TextGrid > automatic transcript > audio-only.

`automatic_words` is the one step the pipeline, CLI, app and user-study batch share for the third option.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..align import Word
from .model import RecognizerUnavailable
from .transcribe import Transcript, transcribe

TYPED, TEXTGRID, AUTOMATIC, AUDIO_ONLY = "typed transcript", "TextGrid", "automatic transcript", "audio only"


def transcript_source(text: str | None, has_textgrid: bool, auto: bool) -> str:
    """The source a request uses, in priority order (a typed transcript wins over a TextGrid)."""
    if text and text.strip():
        return TYPED
    if has_textgrid:
        return TEXTGRID
    return AUTOMATIC if auto else AUDIO_ONLY


@dataclass
class AutomaticWords:
    words: list[Word] | None         # None: audio-only
    text_mode: str                   # said to the user
    transcript: Transcript | None    # None when the recogniser is not installed
    warnings: list[str] = field(default_factory=list)


def automatic_words(audio_16k: np.ndarray) -> AutomaticWords:
    """Recognise (N,) float32 16 kHz speech; words when accepted, else audio-only with the reason."""
    try:
        tr = transcribe(audio_16k)
    except RecognizerUnavailable as exc:
        return AutomaticWords(None, "audio-only (automatic transcription unavailable)", None,
                              [f"Automatic transcription is unavailable: {exc}. Generating from the audio only."])
    if not tr.accepted:
        return AutomaticWords(None, "audio-only (automatic transcription rejected)", tr, list(tr.warnings))
    mode = (f"automatic transcript ({len(tr.words)} words recognised, confidence {tr.confidence:.2f}, "
            f"word timings: {tr.timing_method})")
    return AutomaticWords(tr.words, mode, tr, list(tr.warnings))
