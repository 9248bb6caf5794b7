"""The long-audio window loop every backend samples in: speech of any length as overlapping windows of latents,
each seeded by the end of the one before.

Window i covers latents [i * stride, i * stride + t) with stride = t - s (s seed latents of overlap). Window 0
starts from the backend's first seed; window i's seed is the last s latents window i - 1 generated, i.e.
exactly the overlap, which window i generates again in context. The overlap is either cross-faded linearly
(old version fading out, new fading in: no jump at borders) or kept as window i - 1 generated it. The last
window may reach past the speech: the caller pads its condition and crops the result.
"""
from __future__ import annotations

import math
from typing import Callable

import torch

from ..constants import Progress
# sample(window index, first latent, seed latents, noise generator) -> (B, t, ...) latents, time on dim 1
WindowSampler = Callable[[int, int, torch.Tensor, torch.Generator], torch.Tensor]


def window_layout(num_latents: int, t: int, s: int) -> list[int]:
    """First latent of every window so that [0, num_latents) is covered."""
    stride = t - s
    n = max(1, math.ceil(max(num_latents - s, 1) / stride))
    return [i * stride for i in range(n)]


@torch.no_grad()
def sample_windows(num_latents: int, t: int, s: int, first_seed: torch.Tensor, sample: WindowSampler, seed: int,
                   crossfade: bool = True, progress: Progress | None = None) -> torch.Tensor:
    """(B, starts[-1] + t, ...) latents for `num_latents` (or more: whole windows), on the CPU. `sample` is called
    once per window, in order, with the window's seed (the last `s` latents of the window before, or
    `first_seed`) and one CPU generator seeded with `seed` for all windows' noise."""
    starts = window_layout(num_latents, t, s)
    g = torch.Generator(device="cpu").manual_seed(int(seed))
    ramp = torch.arange(1, s + 1, dtype=torch.float32) / (s + 1)    # weight of the new window in the overlap
    out, seed_lat = None, first_seed
    for i, st in enumerate(starts):
        x = sample(i, st, seed_lat, g).cpu()
        if out is None:
            out = x.new_zeros(x.shape[0], starts[-1] + t, *x.shape[2:])
            out[:, :t] = x
        else:
            if crossfade:
                w = ramp.reshape(1, s, *([1] * (x.ndim - 2)))
                out[:, st:st + s] = out[:, st:st + s] * (1 - w) + x[:, :s] * w
            out[:, st + s:st + t] = x[:, s:]
        seed_lat = x[:, t - s:]
        if progress:
            progress((i + 1) / len(starts), f"window {i + 1}/{len(starts)}")
    return out
