"""The long-audio window loop every backend samples in: speech of any length as overlapping windows of latents,
each seeded by the end of the one before.

Window i covers latents [i * stride, i * stride + t) with stride = t - s (s seed latents of overlap). Window 0
starts from the backend's first seed; window i's seed is the last s latents window i - 1 generated, i.e.
exactly the overlap, which window i generates again in context. The overlap is either cross-faded linearly
(old version fading out, new fading in: no jump at borders) or kept as window i - 1 generated it. The last
window may reach past the speech: the caller pads its condition and crops the result.

Held latents (edits, `Held`): where `mask` is True the latents are known. A window with nothing unknown among its
latents before `num_latents` is not sampled (its latents are the known ones, no noise is drawn), so an edit costs
only the windows it touches; a sampled window is asked for the unknown ones (the sampler holds the known ones while
sampling, flows/base.py `inpainting`) and its known entries are set back to the known values, as is the result.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import torch

from ..constants import Progress
from .base import hold
# sample(window index, first latent, seed latents, noise generator) -> (B, t, ...) latents, time on dim 1
WindowSampler = Callable[[int, int, torch.Tensor, torch.Generator], torch.Tensor]


@dataclass(frozen=True)
class Held:
    """Latents known before sampling: `known` (B, n, ...) like the loop's output, time on dim 1; `mask`
    broadcastable to it, bool (True where known) or float weights in [0, 1] (how much of the known value is held:
    flows/base.py `hold`). Positions past n (the last window's padding) are unknown."""
    known: torch.Tensor
    mask: torch.Tensor

    def padded(self, total: int) -> "Held":
        n = self.known.shape[1]
        if total <= n:
            return Held(self.known[:, :total], self.mask[:, :total])

        def pad(a: torch.Tensor) -> torch.Tensor:
            return torch.cat([a, torch.zeros(a.shape[0], total - n, *a.shape[2:], dtype=a.dtype)], 1)
        return Held(pad(self.known), pad(self.mask))

    def window(self, start: int, t: int) -> "Held":
        return Held(self.known[:, start:start + t], self.mask[:, start:start + t])

    def hold(self, x: torch.Tensor) -> torch.Tensor:
        """x with the known entries set to their values (mixed, where the mask is a weight)."""
        return hold(x, self.known.to(x), self.mask if self.mask.dtype == torch.bool else self.mask.to(x))

    def full(self) -> "Held":
        """Only the entries known in full (a bool mask)."""
        return self if self.mask.dtype == torch.bool else Held(self.known, self.mask >= 1)

    def all_known(self) -> bool:
        return bool(self.full().mask.all())


def window_layout(num_latents: int, t: int, s: int) -> list[int]:
    """First latent of every window so that [0, num_latents) is covered."""
    stride = t - s
    n = max(1, math.ceil(max(num_latents - s, 1) / stride))
    return [i * stride for i in range(n)]


def sampled_windows(num_latents: int, t: int, s: int, held: Held | None = None) -> list[int]:
    """Indices of the windows `sample_windows` samples: all, or with `held` those with an unknown latent."""
    starts = window_layout(num_latents, t, s)
    if held is None:
        return list(range(len(starts)))
    held = held.padded(starts[-1] + t)
    return [i for i, st in enumerate(starts) if not held.window(st, min(t, num_latents - st)).all_known()]


@torch.no_grad()
def sample_windows(num_latents: int, t: int, s: int, first_seed: torch.Tensor, sample: WindowSampler, seed: int,
                   crossfade: bool = True, progress: Progress | None = None, held: Held | None = None,
                   on_window: Callable[[int, torch.Tensor], None] | None = None) -> torch.Tensor:
    """(B, starts[-1] + t, ...) latents for `num_latents` (or more: whole windows), on the CPU. `sample` is called
    once per window, in order, with the window's seed (the last `s` latents of the window before, or
    `first_seed`) and one CPU generator seeded with `seed` for all windows' noise. `held`: known latents (module
    docstring); windows with nothing unknown are not sampled. `on_window(n, out)` after each window: the first `n`
    latents of `out` are final (no later window's cross-fade reaches them); it must only read `out`."""
    starts = window_layout(num_latents, t, s)
    g = torch.Generator(device="cpu").manual_seed(int(seed))
    ramp = torch.arange(1, s + 1, dtype=torch.float32) / (s + 1)    # weight of the new window in the overlap
    todo = set(sampled_windows(num_latents, t, s, held))
    held = held.padded(starts[-1] + t) if held is not None else None
    out, seed_lat = None, first_seed
    for i, st in enumerate(starts):
        if held is not None and i not in todo:           # only held windows are skipped
            x = held.known[:, st:st + t].clone()
        else:
            x = sample(i, st, seed_lat, g).cpu()
            x = held.window(st, t).hold(x) if held is not None else x
        if out is None:
            out = x.new_zeros(x.shape[0], starts[-1] + t, *x.shape[2:])
            out[:, :t] = x
        else:
            if crossfade:
                w = ramp.reshape(1, s, *([1] * (x.ndim - 2)))
                out[:, st:st + s] = out[:, st:st + s] * (1 - w) + x[:, :s] * w
            out[:, st + s:st + t] = x[:, s:]
        seed_lat = x[:, t - s:]
        if on_window is not None:
            on_window(starts[i + 1] if i + 1 < len(starts) else starts[-1] + t, out)
        if progress:
            progress((i + 1) / len(starts), f"window {i + 1}/{len(starts)}")
    assert out is not None                                          # a layout has at least one window
    return held.full().hold(out) if held is not None else out      # exact again after the cross-fades
