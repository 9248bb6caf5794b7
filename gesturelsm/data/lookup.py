"""Recognise speech as a take of a BEAT2-layout folder (to show its ground-truth motion beside generated ones)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import soundfile as sf

from ..audio import SAMPLE_RATE, load_audio
from ..motion.sequence import MotionSequence
from .beat2 import Beat2Dataset, DatasetError


def find_beat2_take(root: str | Path | None, audio: np.ndarray, filename: str | None = None) -> str | None:
    """Name of the BEAT2 take whose speech the upload is (same file name, or same length and samples).
    `audio`: (N,) 16 kHz mono."""
    if not root:
        return None
    try:
        ds = Beat2Dataset(root)
    except DatasetError:
        return None
    stem = Path(filename).stem if filename else None
    if stem and stem in ds.names:
        return stem
    n = len(audio)
    for name in ds.names:
        wav = ds.wave_dir / f"{name}.wav"
        if not wav.exists():
            continue
        try:
            info = sf.info(str(wav))
        except Exception:
            continue
        if abs(info.frames / info.samplerate - n / SAMPLE_RATE) > 0.05:
            continue
        ref = load_audio(wav)
        k = min(len(ref), n, SAMPLE_RATE * 5)
        a, b = audio[:k], ref[:k]
        if k > 0 and np.corrcoef(a, b)[0, 1] > 0.98:
            return name
    return None


def take_motion(root: str | Path, name: str) -> MotionSequence:
    """The ground-truth motion of take `name`."""
    return Beat2Dataset(root).load(name, with_audio=False, with_text=False).motion


__all__ = ["find_beat2_take", "take_motion"]
