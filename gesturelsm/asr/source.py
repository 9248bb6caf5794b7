"""Which transcript a request uses: typed transcript > TextGrid > automatic transcript > audio-only.

`automatic_words` is the one step the pipeline, CLI, app and user-study batch share for the third option. It
remembers its last results by the audio's content (`RECENT`), and a call for audio that another thread is already
transcribing waits for that result instead of transcribing it twice: the page starts transcribing an upload while the
visitor still chooses the settings (`GestureService.prefetch`), and the click then finds the words ready.
"""
from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from ..align import Word
from ..memo import Recent
from ..align.languages import typed_alignment as typed_alignment  # re-exported: its home is the aligner
from .languages import AUTO, ENGLISH, NOT_FOR_GESTURES, gesture_words, name
from .model import RecognizerUnavailable
from .transcribe import Piece, Transcript, transcribe

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
    seconds: float = 0.0             # wall seconds the recognition took, when and wherever it ran
    earlier: bool = False            # recognised before this call (remembered, or prefetched by another process)


RECENT: Recent[AutomaticWords] = Recent(8)


def _key(y: np.ndarray) -> tuple[int, bytes]:
    return len(y), hashlib.blake2b(y.tobytes(), digest_size=16).digest()


def automatic_words(audio_16k: np.ndarray, remember: bool = True, language: str = AUTO,
                    on_piece: Callable[[Piece], None] | None = None) -> AutomaticWords:
    """Recognise (N,) float32 16 kHz speech in `language` (languages.CHOICES; AUTO: English, else the language the
    multilingual model identifies); the same samples and language again: the remembered answer, see the module doc;
    remember=False recognises afresh and keeps nothing. `on_piece`: each recognition window's English words as soon as
    they are timed (transcribe's `on_piece`; not called for a remembered answer)."""
    y = np.ascontiguousarray(audio_16k, np.float32).reshape(-1)
    more = [on_piece] if on_piece else []
    if not remember:
        return _timed(y, language, *more)
    here = []
    got = RECENT.get((*_key(y), language), lambda: here.append(1) or _timed(y, language, *more))
    return replace(got, words=list(got.words) if got.words is not None else None, warnings=list(got.warnings),
                   earlier=not here)


def _timed(audio_16k: np.ndarray, language: str = AUTO, *on_piece: Callable[[Piece], None]) -> AutomaticWords:
    t0 = time.perf_counter()
    got = _recognised(audio_16k, language, *on_piece)
    return replace(got, seconds=time.perf_counter() - t0)


def warm_up(audio_16k: np.ndarray) -> None:
    """Recognise `audio_16k` once, keeping nothing (the model loaded, its kernels chosen; "unavailable" said when it is
    not installed), and ready the aligner that times the words (align/dtw.py: its compiled recursion loaded)."""
    from ..align.dtw import warm

    automatic_words(audio_16k, remember=False)
    warm()


def remember_words(audio_16k: np.ndarray, words: AutomaticWords, language: str = AUTO) -> None:
    """Keep `words`, recognised from these samples in another process (the web demo's replicas), as if recognised
    here: `automatic_words` of the same samples and language returns them."""
    y = np.ascontiguousarray(audio_16k, np.float32).reshape(-1)
    RECENT.get((*_key(y), language), lambda: words)


def _recognised(audio_16k: np.ndarray, language: str = AUTO,
                on_piece: Callable[[Piece], None] | None = None) -> AutomaticWords:
    """Recognise (N,) float32 16 kHz speech; words when accepted, else audio-only with the reason."""
    try:
        tr = transcribe(audio_16k, language=language, **({"on_piece": on_piece} if on_piece else {}))
    except RecognizerUnavailable as exc:
        return AutomaticWords(None, "audio-only (automatic transcription unavailable)", None,
                              [f"Automatic transcription is unavailable: {exc}. Generating from the audio only."])
    if not tr.accepted:
        return AutomaticWords(None, "audio-only (automatic transcription rejected)", tr, list(tr.warnings))
    said = (f"{len(tr.words)} words recognised{language_said(tr)}, confidence {tr.confidence:.2f}, word timings: "
            f"{tr.timing_method}")
    if not gesture_words(tr.language, tr.text):
        return AutomaticWords(None, f"audio-only ({said}: \"{tr.text}\"; {NOT_FOR_GESTURES})", tr, list(tr.warnings))
    return AutomaticWords(tr.words, f"automatic transcript ({said})", tr, list(tr.warnings))


def language_said(tr: Transcript) -> str:
    """", in Japanese (identified, probability 0.92)" for speech not heard by the English model; "" for English."""
    if tr.language == ENGLISH and tr.language_probability is None:
        return ""
    how = "chosen" if tr.language_probability is None else f"identified, probability {tr.language_probability:.2f}"
    return f" in {name(tr.language)} ({how})"
