"""Loading speech from any common file: -> float32 mono at the requested rate (16 kHz by default).

Errors are `AudioError` with a message a person understands (what file, what is wrong, what to do).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..constants import SAMPLE_RATE
from ..errors import AudioError
from .containers import describe_seconds, ffmpeg_input_args, probe_duration, sniff_container


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


MAX_CHANNELS = 8                # more is not speech; block-wise downmixing keeps memory bounded anyway
MAX_SAMPLE_RATE = 192_000
_BLOCK = 1 << 16                # frames per block when reading with libsndfile


class AudioTooLongError(AudioError):
    """Audio longer than the caller's limit (refused before it is decoded in full)."""


def load_audio(path: str | Path, sr: int = SAMPLE_RATE, max_seconds: float | None = None) -> np.ndarray:
    """Read wav/flac/ogg/mp3/m4a/webm... -> (N,) float32 mono at `sr`.

    The container is recognised by its content, on an allow-list (`containers.py`): playlists and
    anything else are refused before a decoder sees them. With `max_seconds`, the header's duration is
    checked first and decoding stops one sample past the limit (`AudioTooLongError`), so memory and time
    stay bounded by the limit, not by what the file claims or contains. soundfile reads wav/flac/ogg/mp3/
    aiff block by block (downmixed per block); other containers, and files libsndfile rejects, are decoded
    with the ffmpeg binary that imageio-ffmpeg bundles, pinned to the sniffed demuxer.
    """
    path = Path(path)
    if not path.exists():
        raise AudioError(f"Audio file not found: {path}")
    if path.stat().st_size == 0:
        raise AudioError(f"Audio file {path.name} is empty (0 bytes).")
    container = sniff_container(path)
    if container is None:
        raise AudioError(f"{path.name} is not an audio file this app reads (by its content it is none of WAV, "
                         "FLAC, MP3, OGG, AAC, M4A, WebM, AIFF, CAF, WMA or AMR; playlists and links are not "
                         "followed).")
    if max_seconds is not None:
        stated = probe_duration(path, container)
        if stated is not None and stated > max_seconds:
            raise AudioTooLongError(f"{path.name} is {describe_seconds(stated)} long; the limit is "
                                    f"{describe_seconds(max_seconds)}.")
    y, sr_in = None, sr
    if container.soundfile:
        try:
            y, sr_in = _read_with_soundfile(path, max_seconds)
        except AudioError:
            raise
        except Exception:
            y = None
    if y is None:
        y, sr_in = _decode_with_ffmpeg(path, sr, container, max_seconds)
    if max_seconds is not None and len(y) > max_seconds * sr_in:
        raise AudioTooLongError(f"{path.name} is longer than the limit of {describe_seconds(max_seconds)}.")
    if len(y) == 0:
        raise AudioError(f"Audio file {path.name} contains no samples.")
    if not np.isfinite(y).all():
        raise AudioError(f"Audio file {path.name} contains invalid (NaN/inf) samples.")
    return resample(y, int(sr_in), sr)


def _read_with_soundfile(path: Path, max_seconds: float | None) -> tuple[np.ndarray, int]:
    """(N,) float32 mono at the file's rate, read in blocks of at most _BLOCK frames and stopped one frame
    past max_seconds; raises AudioError for channel counts or rates that are not speech."""
    import soundfile as sf

    with sf.SoundFile(str(path)) as f:
        if f.channels > MAX_CHANNELS:
            raise AudioError(f"{path.name} has {f.channels} channels; speech needs 1 or 2 (at most {MAX_CHANNELS}).")
        if not 0 < f.samplerate <= MAX_SAMPLE_RATE:
            raise AudioError(f"{path.name} has a sample rate of {f.samplerate} Hz; at most {MAX_SAMPLE_RATE} Hz "
                             "is accepted.")
        limit = -1 if max_seconds is None else int(max_seconds * f.samplerate) + 1
        parts = [b.mean(axis=1) for b in f.blocks(blocksize=_BLOCK, frames=limit, dtype="float32", always_2d=True)]
        return (np.concatenate(parts) if parts else np.zeros(0, np.float32)), int(f.samplerate)


def _decode_with_ffmpeg(path: Path, sr: int, container=None, max_seconds: float | None = None
                        ) -> tuple[np.ndarray, int]:
    import subprocess

    import imageio_ffmpeg

    container = container or sniff_container(path)
    if container is None:
        raise AudioError(f"{path.name} is not an audio file this app reads.")
    limit = [] if max_seconds is None else ["-t", f"{max_seconds + 1.0 / sr:.6f}"]
    cmd = [imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-nostdin", *ffmpeg_input_args(path, container), *limit,
           "-vn", "-ac", "1", "-ar", str(sr), "-f", "f32le", "-"]
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
