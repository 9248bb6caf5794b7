"""Loading speech from any common file: -> float32 mono at the requested rate (16 kHz by default).

Errors are `AudioError` with a message a person understands (what file, what is wrong, what to do).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .constants import SAMPLE_RATE
from .errors import AudioError



def resample(y: np.ndarray, sr_in: int, sr_out: int = SAMPLE_RATE) -> np.ndarray:
    """Band-limited polyphase resampling (scipy), exact length round(len * sr_out / sr_in)."""
    if sr_in == sr_out:
        return y.astype(np.float32, copy=False)
    from scipy.signal import resample_poly

    g = math.gcd(int(sr_in), int(sr_out))
    out = resample_poly(y.astype(np.float64), sr_out // g, sr_in // g)
    n = int(round(len(y) * sr_out / sr_in))
    return out[:n].astype(np.float32)


def to_mono(y: np.ndarray) -> np.ndarray:
    """(N,) or (N, C) -> (N,) float32 in [-1, 1]; integer PCM is scaled by its full range."""
    y = np.asarray(y)
    if np.issubdtype(y.dtype, np.integer):
        info = np.iinfo(y.dtype)
        y = (y.astype(np.float64) - (info.max + info.min + 1) / 2) / (info.max + 1)
    y = y.astype(np.float32)
    if y.ndim == 2:
        y = y.mean(axis=1) if y.shape[1] <= 16 else y.mean(axis=0)
    return y.reshape(-1)


def load_audio(path: str | Path, sr: int = SAMPLE_RATE) -> np.ndarray:
    """Read wav/flac/ogg/mp3/m4a/webm... -> (N,) float32 mono at `sr`.

    soundfile reads wav/flac/ogg (float or int PCM, any rate); other containers are decoded with the
    ffmpeg binary that imageio-ffmpeg bundles.
    """
    path = Path(path)
    if not path.exists():
        raise AudioError(f"Audio file not found: {path}")
    if path.stat().st_size == 0:
        raise AudioError(f"Audio file {path.name} is empty (0 bytes).")
    import soundfile as sf

    try:
        y, sr_in = sf.read(str(path), always_2d=False)
    except Exception:
        y, sr_in = _decode_with_ffmpeg(path, sr)
    y = to_mono(y)
    if len(y) == 0:
        raise AudioError(f"Audio file {path.name} contains no samples.")
    if not np.isfinite(y).all():
        raise AudioError(f"Audio file {path.name} contains invalid (NaN/inf) samples.")
    return resample(y, int(sr_in), sr)


def _decode_with_ffmpeg(path: Path, sr: int) -> tuple[np.ndarray, int]:
    import subprocess

    import imageio_ffmpeg

    cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-nostdin", "-i", str(path), "-vn", "-ac", "1",
           "-ar", str(sr), "-f", "f32le", "-"]
    try:
        proc = subprocess.run(cmd, capture_output=True, timeout=300)
    except subprocess.TimeoutExpired:
        raise AudioError(f"Decoding {path.name} took too long; is it a valid audio file?") from None
    if proc.returncode != 0 or not proc.stdout:
        msg = proc.stderr.decode(errors="replace").strip().splitlines()
        detail = msg[-1] if msg else "no audio stream"
        raise AudioError(f"Could not read {path.name} as audio ({detail}). "
                         "Use a common format such as WAV, FLAC, MP3, OGG or M4A.")
    return np.frombuffer(proc.stdout, np.float32).copy(), sr
