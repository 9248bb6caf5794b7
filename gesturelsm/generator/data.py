"""Training tensors for the generator: per take, region latents from the frozen tokenizers, audio channels
and per-frame word vectors; random windows with their seed latents.

Latent space: the tokenizers' continuous encoder outputs (before quantisation), divided per region by their
std over the training data (`latent_std`), so every region enters the flow at unit scale.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from ..audio import SAMPLE_RATE
from ..errors import DatasetError
from ..features.audio import audio_channels
from ..features.text import TEXT_DIM, TextEmbedder
from ..motion.regions import REGIONS
from ..motion.sequence import FPS, mirror_features
from ..tokenizer.evaluate import pad_to_multiple
from ..tokenizer.model import RVQVAE


@dataclass
class TakeTensors:
    name: str
    latents: torch.Tensor      # (R, L, D) encoder outputs (un-scaled)
    audio: torch.Tensor        # (2, N) audio channels at 16 kHz, N = 4L frames worth of samples
    words: torch.Tensor        # (4L, 384) word vectors per frame
    has_word: torch.Tensor     # (4L,) bool
    has_text: bool


@torch.no_grad()
def encode_regions(tokenizers: dict[str, RVQVAE], feats: torch.Tensor) -> torch.Tensor:
    """(T, 433) raw features -> (R, ceil(T/4), D) continuous latents, regions in `tokenizers` order."""
    out = []
    for region, tok in tokenizers.items():
        x, _ = pad_to_multiple(tok.normalizer.normalize(feats[:, list(REGIONS[region].columns)]), 4)
        out.append(tok.encode(x[None])[0])
    return torch.stack(out)


def samples_for(frames: int) -> int:
    return int(round(frames * SAMPLE_RATE / FPS))


def build_take(name: str, feats: torch.Tensor, audio: np.ndarray, words, tokenizers: dict[str, RVQVAE],
               embedder: TextEmbedder | None, mirror: bool = False) -> TakeTensors:
    """feats: (T, 433) raw; audio: (>= T frames of) 16 kHz samples; words: list[Word] or None."""
    T = feats.shape[0] // 4 * 4
    feats = feats[:T]
    if mirror:
        feats = mirror_features(feats)
    lat = encode_regions(tokenizers, feats)
    y = np.zeros(samples_for(T), np.float32)
    y[: min(len(y), len(audio))] = audio[: len(y)]
    ch = torch.from_numpy(audio_channels(y))
    if words is not None and embedder is not None and embedder.available:
        ft = embedder.frame_features(words, T)
        wv, hw, has_text = torch.from_numpy(ft.features), torch.from_numpy(ft.has_word), True
    else:
        wv, hw, has_text = torch.zeros(T, TEXT_DIM), torch.zeros(T, dtype=torch.bool), False
    return TakeTensors(name + ("~mirror" if mirror else ""), lat, ch, wv, hw, has_text)


@dataclass
class Batch:
    x1: torch.Tensor        # (B, R, t, D) target latents (scaled)
    seed: torch.Tensor      # (B, R, s, D) scaled
    audio: torch.Tensor     # (B, 2, N)
    words: torch.Tensor     # (B, 4t, 384)
    has_word: torch.Tensor  # (B, 4t)
    has_text: torch.Tensor  # (B,)

    def to(self, device) -> "Batch":
        return Batch(*(v.to(device) for v in (self.x1, self.seed, self.audio, self.words, self.has_word,
                                                self.has_text)))


class LatentWindowSampler:
    def __init__(self, takes: list[TakeTensors], window: int, seed_len: int, latent_std: torch.Tensor,
                 neutral_seed: torch.Tensor, p_neutral_seed: float = 0.1, p_no_text: float = 0.2, seed: int = 0,
                 seed_noise: float = 0.0):
        self.takes = [tk for tk in takes if tk.latents.shape[1] >= window]
        if not self.takes:
            raise DatasetError(f"no take has {window * 4} frames (one generator window)")
        self.window, self.seed_len = window, seed_len
        self.std = latent_std.reshape(-1, 1, 1)
        self.neutral = neutral_seed
        self.p_neutral, self.p_no_text = p_neutral_seed, p_no_text
        self.seed_noise = seed_noise      # std of Gaussian noise on real seeds (scaled latents): at inference the
                                          # seed is the previous window's *generated* overlap, not real motion
        self.g = torch.Generator().manual_seed(seed)
        n = torch.tensor([tk.latents.shape[1] - window + 1 for tk in self.takes], dtype=torch.float)
        self.weights = n / n.sum()

    def sample(self, B: int) -> Batch:
        t, s = self.window, self.seed_len
        xs, seeds, auds, wvs, hws, hts = [], [], [], [], [], []
        n_samp = samples_for(4 * t)
        for i in torch.multinomial(self.weights, B, replacement=True, generator=self.g).tolist():
            tk = self.takes[i]
            st = int(torch.randint(0, tk.latents.shape[1] - t + 1, (1,), generator=self.g))
            xs.append(tk.latents[:, st:st + t] / self.std)
            # the seed is the window's own first s latents: at inference they are the overlap that the
            # previous window generated (see sampling.py)
            if torch.rand((), generator=self.g) >= self.p_neutral:
                clean = tk.latents[:, st:st + s] / self.std
                seeds.append(clean + self.seed_noise * torch.randn(clean.shape, generator=self.g)
                             if self.seed_noise > 0 else clean)
            else:
                seeds.append(self.neutral)
            a0 = samples_for(4 * st)
            a = tk.audio[:, a0:a0 + n_samp]
            auds.append(torch.nn.functional.pad(a, (0, n_samp - a.shape[1])))
            wvs.append(tk.words[4 * st:4 * (st + t)])
            hws.append(tk.has_word[4 * st:4 * (st + t)])
            hts.append(tk.has_text and bool(torch.rand((), generator=self.g) >= self.p_no_text))
        return Batch(torch.stack(xs), torch.stack(seeds), torch.stack(auds), torch.stack(wvs), torch.stack(hws),
                     torch.tensor(hts))
