"""The reference's speech condition: features as the released models were trained on, and their encoder.

Features (per 16 kHz sample, 2 channels), as the reference's data cache computed them:
  0: amplitude envelope = max |y| over the next 1024 samples (the last 1023 samples repeat the last value);
  1: onset "impulses" = librosa onset-detector *frame indices* (hop 512) written as if they were sample
     indices, so the ones sit in the first ~1/512 of the clip (a bug of their code, docs/AUTHORS-CODE.md; the
     released weights were trained on it, so it is reproduced here; our own models use real positions).
The reference computes them after loading the file at 22.05 kHz and resampling to 16 kHz (librosa's
defaults); `features_from_file` does the same, `speech_features` starts from 16 kHz samples.
Encoder: 6 strided residual conv blocks (k15, BatchNorm, LeakyReLU 0.01) -> exactly `frames` steps;
words: trained embedding (300-d) -> linear; concat -> linear to 3C -> average pool x4 -> (B, 32, 3C).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F

from ..errors import AudioError
from ..features.audio import envelope
from ..kernels import WeightsCache, channels_last_1d, conv1d_as_2d, conv1d_as_2d_add_, onednn_enabled, taken
from .config import GeneratorConfig

ENVELOPE_WINDOW = 1024
PROBE_SAMPLES = 32768      # the encoder's fast path is measured on this much of one clip (~2 s)
PAD_TOKEN, UNK_TOKEN = 0, 3


def speech_features(y: np.ndarray, sr: int = 16000) -> np.ndarray:
    """16 kHz mono (T,) -> (T, 2) float [envelope, onset channel as trained]."""
    import librosa

    y = np.ascontiguousarray(y, dtype=np.float32)
    n = y.shape[0]
    if n < ENVELOPE_WINDOW:
        raise AudioError(f"speech shorter than {ENVELOPE_WINDOW} samples ({n / sr:.3f} s)")
    env = envelope(y, ENVELOPE_WINDOW)                      # exact forward-window maxima (doubling passes)
    env[n - ENVELOPE_WINDOW + 1:] = env[n - ENVELOPE_WINDOW]  # the reference repeats the last full window
    onset = np.zeros(n, dtype=np.float64)
    onset[librosa.onset.onset_detect(y=y, sr=sr, units="frames")] = 1.0  # frame indices as sample indices
    return np.stack([env.astype(np.float64), onset], axis=1)


def features_from_file(path: str | Path) -> np.ndarray:
    """The reference's file path: librosa.load at its default 22.05 kHz, resample to 16 kHz, features."""
    import librosa

    y, sr = librosa.load(str(path))
    return speech_features(librosa.resample(y, orig_sr=sr, target_sr=16000))


def word_tokens(intervals: list[tuple[float, float, str]], num_frames: int, word2index: dict[str, int],
                fps: int = 30) -> np.ndarray:
    """Per 30 fps frame i: the first interval with start <= i/fps <= end; ' ' -> PAD, unknown -> UNK."""
    out = np.full(num_frames, UNK_TOKEN, dtype=np.int64)
    for i in range(num_frames):
        t = i / fps
        for start, end, mark in intervals:
            if start <= t <= end:
                out[i] = PAD_TOKEN if mark == " " else word2index.get(mark, UNK_TOKEN)
                break
    return out


class ConvBN(nn.Module):
    def __init__(self, cin: int, cout: int, stride: int, pad: int):
        super().__init__()
        self.conv = nn.Conv1d(cin, cout, 15, stride, pad)
        self.bn = nn.BatchNorm1d(cout)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.bn(self.conv(x))

    def folded(self) -> tuple[torch.Tensor, torch.Tensor]:
        """Eval-mode BatchNorm folded into the convolution: (Cout, Cin, 1, k) channels-last weight, (Cout,) bias."""
        bn, conv = self.bn, self.conv
        s = bn.weight / torch.sqrt(bn.running_var + bn.eps)
        w = (conv.weight * s[:, None, None])[:, :, None].contiguous(memory_format=torch.channels_last)
        return w, (conv.bias - bn.running_mean) * s + bn.bias

    def fast(self, x: torch.Tensor, folded: tuple[torch.Tensor, torch.Tensor]) -> torch.Tensor:
        """forward() in eval mode on channels-last (B, C, 1, T) input, with `folded()` weights."""
        return conv1d_as_2d(x, *folded, self.conv.stride[0], self.conv.padding[0])


class WavBlock(nn.Module):
    """conv(k15, stride) BN LReLU conv(k15) BN + shortcut (strided conv BN when downsampling) -> LReLU."""

    def __init__(self, cin: int, cout: int, stride: int, pad: int, down: bool):
        super().__init__()
        self.a = ConvBN(cin, cout, stride, pad)
        self.b = ConvBN(cout, cout, 1, 7)
        self.down = ConvBN(cin, cout, stride, pad) if down else None

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = self.b(F.leaky_relu(self.a(x), 0.01))
        return F.leaky_relu(h + (self.down(x) if self.down is not None else x), 0.01)

    def fast(self, x: torch.Tensor, folded: list) -> torch.Tensor:
        """forward() in eval mode on channels-last (B, C, 1, T) input; folded = [a, b, down] folded weights.
        Without a downsampling branch the residual is x itself, and the result is written into x."""
        h = F.leaky_relu_(self.a.fast(x, folded[0]), 0.01)          # in place: fresh buffers cost page faults
        res = self.down.fast(x, folded[2]) if self.down is not None else x
        conv1d_as_2d_add_(res, h, *folded[1], self.b.conv.stride[0], self.b.conv.padding[0])
        return F.leaky_relu_(res, 0.01)


# (out channels as a fraction of audio_dim, stride, padding, downsample); total stride 540
WAV_PLAN = ((4, 5, 1700, True), (4, 6, 0, True), (4, 1, 7, False), (2, 6, 0, True), (2, 1, 7, False), (1, 3, 0, True))


class ReferenceSpeechEncoder(nn.Module):
    """audio (B, S, 2) samples + words (B, frames) -> speech features (B, frames / 4, regions * latent_dim)."""

    def __init__(self, cfg: GeneratorConfig):
        super().__init__()
        self.cfg = cfg
        blocks, cin = [], 2
        for div, stride, pad, down in WAV_PLAN:
            blocks.append(WavBlock(cin, cfg.audio_dim // div, stride, pad, down))
            cin = cfg.audio_dim // div
        self.wav = nn.Sequential(*blocks)
        self.word_embedding = nn.Embedding(cfg.vocab_size, cfg.word_dim)
        self.word_proj = nn.Linear(cfg.word_dim, cfg.audio_dim)
        self.mix = nn.Linear(2 * cfg.audio_dim, cfg.regions * cfg.latent_dim)
        self._cache = WeightsCache()

    def _wav(self, audio: torch.Tensor) -> torch.Tensor:
        """(B, S, 2) -> (B, A, T'). In eval mode, where measured faster on this machine (the `conv` path, timed on
        the first PROBE_SAMPLES samples of one clip), the BatchNorms are folded into the convolutions (kept until
        a weight changes) and the convolutions run channels-last (kernels), which makes a window's encoding faster
        there (docs/BENCHMARKS.md, "Why the code is built this way")."""
        a = audio.transpose(1, 2)
        if self.training or torch.is_grad_enabled() or not onednn_enabled():
            return self.wav(a)
        probe = a[:1, :, :PROBE_SAMPLES]
        if not taken("conv", ("reference speech encoder", f"{self.cfg.audio_dim} channels"),
                     lambda: ((lambda: self.wav(probe)), (lambda: self._wav_folded(probe)))):
            return self.wav(a)
        return self._wav_folded(a)

    def _wav_folded(self, a: torch.Tensor) -> torch.Tensor:
        """(B, 2, S) -> (B, A, T'): eval-mode `wav` with folded BatchNorms on channels-last tensors."""
        folded = self.folded_convs()
        x = channels_last_1d(a)                               # may be a view of the caller's audio (same layout)
        if self.wav[0].down is None:
            x = x.clone()                                     # such a block would write into the caller's audio
        for blk, f in zip(self.wav, folded):
            x = blk.fast(x, f)
        return x[:, :, 0]

    def folded_convs(self) -> list[list]:
        """Per conv block [a, b, down] ConvBN.folded() weights, kept until a weight or BatchNorm statistic changes."""
        convs = [c for blk in self.wav for c in (blk.a, blk.b, blk.down) if c is not None]
        with torch.no_grad():
            return self._cache.get("folded", [t for c in convs for t in (*c.parameters(), *c.buffers())],
                                   lambda: [[c.folded() if c is not None else None for c in (blk.a, blk.b, blk.down)]
                                            for blk in self.wav])

    def forward(self, audio: torch.Tensor, words: torch.Tensor) -> torch.Tensor:
        a = self._wav(audio)                                                    # (B, A, T')
        n = self.cfg.frames
        a = a[..., :n] if a.shape[-1] >= n else torch.cat([a, a[..., -1:].expand(-1, -1, n - a.shape[-1])], -1)
        w = self.word_proj(self.word_embedding(words))                          # (B, frames, A)
        h = self.mix(torch.cat([a.transpose(1, 2), w], -1))                     # (B, frames, R*C)
        return F.avg_pool1d(h.transpose(1, 2), 4).transpose(1, 2)               # (B, frames/4, R*C)
