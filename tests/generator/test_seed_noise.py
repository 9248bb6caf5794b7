"""Seed-noise augmentation of the training windows: real seeds get Gaussian noise of the stated std, the windows
themselves and the neutral seed stay exact, and 0 leaves the sampler's batches bit-identical."""
from __future__ import annotations

import torch

from gesturelsm.generator.data import LatentWindowSampler, TakeTensors


def _take(L: int = 64, R: int = 4, D: int = 8) -> TakeTensors:
    g = torch.Generator().manual_seed(0)
    return TakeTensors("t", torch.randn(R, L, D, generator=g) * 3, torch.zeros(2, 4 * L * 534), torch.zeros(4 * L, 384),
                       torch.zeros(4 * L, dtype=torch.bool), False)


def _sampler(noise: float, p_neutral: float = 0.0) -> LatentWindowSampler:
    return LatentWindowSampler([_take()], 16, 2, torch.full((4,), 3.0), torch.full((4, 2, 8), 7.0), p_neutral, 0.0,
                               seed=5, seed_noise=noise)


def test_zero_noise_seeds_are_the_windows_first_latents():
    b = _sampler(0.0).sample(32)
    assert torch.equal(b.seed, b.x1[:, :, :2])


def test_noise_has_the_stated_std_and_leaves_the_window_alone():
    b = _sampler(0.5).sample(256)
    diff = b.seed - b.x1[:, :, :2]
    assert abs(float(diff.std()) - 0.5) < 0.03 and abs(float(diff.mean())) < 0.03
    assert b.x1.std() > 0.9                                         # the windows are real latents / std, unchanged


def test_neutral_seed_gets_no_noise():
    b = _sampler(0.5, p_neutral=1.0).sample(8)
    assert torch.equal(b.seed, torch.full_like(b.seed, 7.0))
