"""The one long-audio window loop: coverage, seeds carried from window to window, the two overlap rules."""
from __future__ import annotations

import torch

from gesturelsm.flows import sample_windows, window_layout


def test_layout_covers_every_latent_with_whole_windows():
    for n in range(1, 200):
        starts = window_layout(n, 32, 4)
        assert starts[0] == 0 and starts[-1] + 32 >= n
        assert all(b - a == 28 for a, b in zip(starts, starts[1:]))
        assert len(starts) == 1 or starts[-2] + 32 < n          # no window more than needed


def _recording_sampler(calls):
    def sample(i, start, seed, g):
        calls.append((i, start, seed.clone()))
        x = torch.full((1, 8, 2), float(i + 1))
        x[:, :, 1] = torch.arange(8.0) + 100 * i                   # distinct values along time
        return x
    return sample


def test_each_window_is_seeded_by_the_end_of_the_one_before():
    calls = []
    first = torch.zeros(1, 2, 2)
    out = sample_windows(20, 8, 2, first, _recording_sampler(calls), seed=0, crossfade=False)
    assert [c[1] for c in calls] == window_layout(20, 8, 2) == [0, 6, 12]
    assert torch.equal(calls[0][2], first)
    for i in range(1, 3):
        prev = torch.full((1, 8, 2), float(i))
        prev[:, :, 1] = torch.arange(8.0) + 100 * (i - 1)
        assert torch.equal(calls[i][2], prev[:, 6:])
    assert out.shape == (1, 20, 2)
    assert torch.equal(out[0, 6:8, 0], torch.tensor([1.0, 1.0]))   # keep: the overlap stays the earlier window's


def test_crossfade_blends_the_overlap_linearly():
    out = sample_windows(10, 8, 2, torch.zeros(1, 2, 2), _recording_sampler([]), seed=0, crossfade=True)
    w = torch.tensor([1 / 3, 2 / 3])
    assert torch.allclose(out[0, 6:8, 0], 1 * (1 - w) + 2 * w)      # old fades out, new fades in
    assert torch.equal(out[0, 8:14, 0], torch.full((6,), 2.0))


def test_noise_comes_from_one_generator_seeded_once():
    draws = []

    def sample(i, start, seed, g):
        draws.append(torch.randn(3, generator=g))
        return torch.zeros(1, 8, 1)

    sample_windows(20, 8, 2, torch.zeros(1, 2, 1), sample, seed=5)
    g = torch.Generator().manual_seed(5)
    assert all(torch.equal(d, torch.randn(3, generator=g)) for d in draws)


def test_held_windows_with_nothing_unknown_are_not_sampled_and_seed_the_next():
    """An edit's loop: windows whose latents are all known are not sampled (no noise drawn), their latents are the
    known ones and seed the next window; sampled windows get their known entries back exactly; so does the result."""
    from gesturelsm.flows import Held, sampled_windows

    known = torch.arange(20 * 2, dtype=torch.float32).reshape(1, 20, 2) / 7
    mask = torch.ones(1, 20, 1, dtype=torch.bool)
    mask[0, 15:17] = False                                           # two unknown latents, in window 2 only
    held = Held(known, mask)
    calls = []
    out = sample_windows(20, 8, 2, torch.zeros(1, 2, 2), _recording_sampler(calls), seed=0, crossfade=True,
                         held=held)
    assert [c[0] for c in calls] == sampled_windows(20, 8, 2, held) == [2]
    assert torch.equal(calls[0][2], known[:, 12:14])                 # seeded by the known end of window 1
    assert torch.equal(out[:, :20][mask.expand_as(known)], known[mask.expand_as(known)])   # held exactly
    assert torch.equal(out[0, 15:17, 0], torch.full((2,), 3.0))      # the sampled window's own latents there


def test_held_mask_as_weights_mixes_the_known_values_in():
    from gesturelsm.flows import Held

    known = torch.ones(1, 10, 1)
    weight = torch.zeros(1, 10, 1)
    weight[0, 4] = 1.0
    weight[0, 5] = 0.25
    out = sample_windows(10, 8, 2, torch.zeros(1, 2, 1), lambda i, st, seed, g: torch.zeros(1, 8, 1), seed=0,
                         crossfade=False, held=Held(known, weight))
    assert out[0, 4, 0] == 1.0 and out[0, 5, 0] == 0.25 and out[0, 3, 0] == 0.0


def test_a_window_reaching_past_the_speech_is_not_sampled_for_its_padding():
    from gesturelsm.flows import Held, sampled_windows

    held = Held(torch.zeros(1, 20, 1), torch.ones(1, 20, 1, dtype=torch.bool))
    assert sampled_windows(20, 8, 2, held) == []                     # the last window's padding is no reason
