"""Frame features and voice activity for alignment, at 50 frames per second for any sample rate.

Frame k is centred on t = k / FRAME_RATE seconds (signals are zero-padded by half a window at both ends), so
a clip of N samples at rate sr has 1 + N * FRAME_RATE // sr frames. Plain numpy (no librosa import).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..constants import SAMPLE_RATE

FRAME_RATE = 50    # frames per second (20 ms hop)
WIN_S = 0.025      # analysis window
N_MFCC = 13
N_MELS = 40
FMIN, FMAX = 50.0, 7600.0


def frame_time(k: np.ndarray | int) -> np.ndarray | float:
    """Seconds at the centre of frame k."""
    return np.asarray(k) / FRAME_RATE


def _frame_blocks(y: np.ndarray, sr: int, block: int = 2000):
    """Yield (t, win) Hann-windowed frames, `block` frames at a time (memory stays flat for long audio).
    Frame k is centred on sample round(k * sr / FRAME_RATE); there are 1 + len(y) * FRAME_RATE // sr."""
    win = int(round(WIN_S * sr))
    n = 1 + len(y) * FRAME_RATE // sr
    pad = np.pad(np.asarray(y, np.float32), (win // 2, win // 2 + sr // FRAME_RATE + 1))
    window = np.hanning(win + 2)[1:-1].astype(np.float32)
    for k0 in range(0, n, block):
        starts = np.round(np.arange(k0, min(n, k0 + block)) * (sr / FRAME_RATE)).astype(np.int64)
        yield pad[starts[:, None] + np.arange(win)[None, :]] * window


@lru_cache(maxsize=8)
def _mel_matrix(sr: int, n_fft: int) -> np.ndarray:
    """(n_fft // 2 + 1, N_MELS) triangular filters, equally spaced on the HTK mel scale."""
    mel = lambda f: 2595.0 * np.log10(1.0 + f / 700.0)  # noqa: E731
    hz = lambda m: 700.0 * (10.0 ** (m / 2595.0) - 1.0)  # noqa: E731
    edges = hz(np.linspace(mel(FMIN), mel(min(FMAX, sr / 2)), N_MELS + 2))
    f = np.arange(n_fft // 2 + 1) * sr / n_fft
    lower, centre, upper = edges[:-2], edges[1:-1], edges[2:]
    up = (f[:, None] - lower) / (centre - lower)
    down = (upper - f[:, None]) / (upper - centre)
    return np.maximum(0.0, np.minimum(up, down)).astype(np.float32)


@lru_cache(maxsize=2)
def _dct_matrix(n_in: int, n_out: int) -> np.ndarray:
    """Orthonormal DCT-II, (n_in, n_out)."""
    k = np.arange(n_out)[None, :]
    x = np.arange(n_in)[:, None]
    d = np.cos(np.pi * k * (2 * x + 1) / (2 * n_in)) * np.sqrt(2.0 / n_in)
    d[:, 0] /= np.sqrt(2.0)
    return d.astype(np.float32)


def mfcc_rows(y: np.ndarray, sr: int = SAMPLE_RATE, n_mfcc: int = N_MFCC) -> np.ndarray:
    """(T, n_mfcc) MFCCs (40 mel bands, 50-7600 Hz) with per-utterance mean/variance normalisation, rows
    scaled to unit length (so a dot product is a cosine similarity)."""
    logmel = []
    for fr in _frame_blocks(y, sr):
        n_fft = 1 << int(np.ceil(np.log2(fr.shape[1])))
        power = np.abs(np.fft.rfft(fr, n_fft, axis=1)) ** 2
        logmel.append(np.log(power @ _mel_matrix(sr, n_fft) + 1e-8))
    m = np.concatenate(logmel) @ _dct_matrix(N_MELS, n_mfcc)
    m = (m - m.mean(0)) / (m.std(0) + 1e-8)
    return (m / np.maximum(np.linalg.norm(m, axis=1, keepdims=True), 1e-8)).astype(np.float32)


def frame_db(y: np.ndarray, sr: int = SAMPLE_RATE) -> np.ndarray:
    """(T,) frame energy in dB re full scale (same frames as `mfcc_rows`)."""
    power = [np.mean(fr.astype(np.float64) ** 2, axis=1) for fr in _frame_blocks(y, sr)]
    return 10.0 * np.log10(np.concatenate(power) * 8.0 / 3.0 + 1e-14)  # 8/3: Hann power loss


@dataclass(frozen=True)
class Activity:
    """Voice activity per frame and the levels it was decided from (dB)."""

    voiced: np.ndarray   # (T,) bool
    floor_db: float      # noise floor estimate
    speech_db: float     # typical loud-frame level

    def segments(self) -> list[tuple[int, int]]:
        """Voiced runs as [start, end) frame pairs."""
        v = np.concatenate([[0], self.voiced.astype(np.int8), [0]])
        d = np.diff(v)
        return list(zip(np.nonzero(d == 1)[0].tolist(), np.nonzero(d == -1)[0].tolist()))


def voice_activity(y: np.ndarray, sr: int = SAMPLE_RATE, min_gap_s: float = 0.0, min_run_s: float = 0.06,
                   ) -> Activity:
    """Energy detector with an adaptive threshold: 35 % of the way from the noise floor (10th percentile)
    to the speech level (95th percentile); bursts up to `min_run_s` are dropped, dips up to `min_gap_s`
    filled (none by default: the short dips of stop closures and word boundaries are where the aligner
    snaps onsets to). Good enough for pauses in speech; music counts as voiced (the DTW skips it)."""
    db = frame_db(y, sr)
    floor, loud = float(np.percentile(db, 10)), float(np.percentile(db, 95))
    voiced = db > floor + 0.35 * max(loud - floor, 0.0)
    if loud - floor < 6.0:  # no level contrast: all one level, voiced unless that level is near silence
        voiced[:] = loud > -50.0
    voiced = flip_short_runs(voiced, False, int(round(min_gap_s * FRAME_RATE)))
    voiced = flip_short_runs(voiced, True, int(round(min_run_s * FRAME_RATE)))
    return Activity(voiced, floor, loud)


def flip_short_runs(x: np.ndarray, value: bool, max_len: int) -> np.ndarray:
    """Flip runs of `value` of at most max_len frames (runs touching either end are kept)."""
    x = x.copy()
    v = np.concatenate([[0], (x == value).astype(np.int8), [0]])
    d = np.diff(v)
    for s, e in zip(np.nonzero(d == 1)[0], np.nonzero(d == -1)[0]):
        if e - s <= max_len and s > 0 and e < len(x):
            x[s:e] = not value
    return x
