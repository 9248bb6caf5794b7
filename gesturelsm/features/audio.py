"""Audio channels and the strided conv audio encoder.

Input speech is 16 kHz mono. Two channels per sample:
- amplitude envelope: max |y| over the forward window [i, i + 1024);
- onset impulses: 1 at the *sample position* of each librosa onset (frame index x hop 512), else 0.
  (The reference wrote onset frame indices into the per-sample array, so almost every onset was lost.)
The encoder maps (B, 2, N) samples to (B, T, C) features, one per 30 fps frame (T = N * 30 / 16000).
"""
from __future__ import annotations

import functools
import threading
import time

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F
from scipy.ndimage import maximum_filter1d

from ..constants import SAMPLE_RATE

SR = SAMPLE_RATE
ENVELOPE_WINDOW = 1024
ONSET_HOP = 512


def envelope(y: np.ndarray, window: int = ENVELOPE_WINDOW) -> np.ndarray:
    """(N,) -> (N,) max |y[i:i+window]| (forward window, shorter at the end).

    For a power-of-two window: doubling maxima m_2w[i] = max(m_w[i], m_w[i + w]) (log2(window) vector passes,
    exact, a few times faster than a sliding-window filter); other windows use scipy's filter."""
    a = np.abs(y).astype(np.float32)
    if window & (window - 1):
        # maximum_filter1d's window for size w and origin o covers [i - w//2 - o, i + (w-1)//2 - o]
        return maximum_filter1d(a, size=window, origin=-(window // 2), mode="constant", cval=0.0)
    m, other, w = a, np.empty_like(a), 1
    while w < window and w < len(a):
        np.maximum(m[:-w], m[w:], out=other[:-w])
        other[-w:] = m[-w:]
        m, other, w = other, m, 2 * w
    return m


N_FFT = 2048


@functools.lru_cache(maxsize=4)
def _mel_basis(sr: int) -> torch.Tensor:
    import librosa

    return torch.from_numpy(librosa.filters.mel(sr=sr, n_fft=N_FFT, n_mels=128, fmax=0.5 * sr))   # (128, 1025)


def log_mel(y: np.ndarray, sr: int = SR, hop: int = ONSET_HOP) -> np.ndarray:
    """(N,) -> (128, 1 + N // hop) log-power mel spectrogram exactly as librosa's onset detector computes it
    (centred frames, zero padding, periodic Hann window, power 2, Slaney mel to sr/2, power_to_db with top_db
    80), with the STFT done by torch (multi-threaded; librosa's is a third of the feature time on long audio)."""
    import librosa

    spec = torch.stft(torch.from_numpy(np.ascontiguousarray(y, np.float32)), N_FFT, hop,
                      window=torch.hann_window(N_FFT),
                      center=True, pad_mode="constant", return_complex=True)
    spec = spec.real.square() + spec.imag.square()                  # |X|^2 without the sqrt of abs(): 3x faster
    return librosa.power_to_db((_mel_basis(sr) @ spec).numpy())


def onset_samples(y: np.ndarray, sr: int = SR, hop: int = ONSET_HOP) -> np.ndarray:
    """Sample positions of speech onsets (librosa's spectral-flux onset detector on `log_mel`)."""
    import librosa

    if len(y) < N_FFT or np.abs(y).max() < 1e-6:
        return np.zeros(0, dtype=np.int64)
    env = librosa.onset.onset_strength(S=log_mel(y, sr, hop), sr=sr, hop_length=hop)
    frames = librosa.onset.onset_detect(onset_envelope=env, sr=sr, hop_length=hop, units="frames")
    return np.asarray(frames, dtype=np.int64) * hop


def audio_channels(y: np.ndarray, sr: int = SR) -> np.ndarray:
    """(N,) float32 16 kHz -> (2, N) float32 [envelope, onset impulses]."""
    if sr != SR:
        raise ValueError(f"audio channels expect {SR} Hz audio, got {sr}")
    imp = np.zeros(len(y), np.float32)
    on = onset_samples(y, sr)
    imp[on[on < len(y)]] = 1.0
    return np.stack([envelope(y), imp])


_warmed = threading.Lock()
_warm = [False]


def warm_audio_features() -> float:
    """librosa's onset kernels compiled (numba: ~2-3 s in a fresh process) on one second of noise, once per process;
    returns the seconds it took (0.0 once done), which are not feature time."""
    t0 = time.perf_counter()
    with _warmed:
        if not _warm[0]:
            audio_channels(np.random.default_rng(0).normal(scale=0.1, size=SR).astype(np.float32))
            _warm[0] = True
    return time.perf_counter() - t0


class ResDown(nn.Module):
    """Strided residual block: conv(k, stride) -> BN -> LeakyReLU -> conv(k) -> BN, plus a strided 1x1 skip."""

    def __init__(self, c_in: int, c_out: int, stride: int, kernel: int = 15):
        super().__init__()
        self.conv1 = nn.Conv1d(c_in, c_out, kernel, stride=stride, padding=kernel // 2)
        self.bn1 = nn.BatchNorm1d(c_out)
        self.conv2 = nn.Conv1d(c_out, c_out, kernel, padding=kernel // 2)
        self.bn2 = nn.BatchNorm1d(c_out)
        self.skip = nn.Conv1d(c_in, c_out, 1, stride=stride)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = F.leaky_relu(self.bn1(self.conv1(x)), 0.2)
        return F.leaky_relu(self.bn2(self.conv2(h)) + self.skip(x), 0.2)


STRIDES = {1: (5, 4, 3, 3, 3, 1), 4: (5, 3, 3, 3, 1, 1)}  # total stride 540 samples with the pre-pool


class AudioEncoder(nn.Module):
    """(B, 2, N) at 16 kHz -> (B, T, out_dim) at 30 fps. Six strided residual blocks, total stride 540
    (5 * 4 * 3 * 3 * 3 * 1), then linear interpolation onto exactly T frames (533.3 samples per frame).

    `pool` = 4 max-pools the two channels to 4 kHz first (strides 5 * 3 * 3 * 3 * 1 * 1 after it): the envelope
    and the onset impulses carry nothing above a few hundred Hz, max-pooling keeps every impulse (at 0.25 ms
    precision), and the convolutions cost about a quarter. The paper's encoder is pool = 1."""

    def __init__(self, channels: tuple[int, ...] = (64, 64, 64, 128, 128, 256), kernel: int = 15, pool: int = 1):
        super().__init__()
        if pool not in STRIDES:
            raise ValueError(f"audio pre-pool must be one of {sorted(STRIDES)}")
        dims = (2,) + tuple(channels)
        self.pool = pool
        self.blocks = nn.Sequential(*[ResDown(dims[i], dims[i + 1], s, kernel) for i, s in enumerate(STRIDES[pool])])
        self.out_dim = channels[-1]

    def forward(self, x: torch.Tensor, num_frames: int) -> torch.Tensor:
        if self.pool > 1:
            x = F.max_pool1d(x, self.pool, ceil_mode=True)
        h = self.blocks(x)                                          # (B, C, ~N / 540)
        h = F.interpolate(h, size=num_frames, mode="linear", align_corners=False)
        return h.transpose(1, 2)                                    # (B, T, C)
