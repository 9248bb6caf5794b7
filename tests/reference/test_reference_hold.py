"""The authors' samplers holding known latents (edits): before every network call the known entries are the known
latents noised to the call's time with the sampler's own noise, by that sampler's forward process; the result has
them exactly; the rest is the sampler's own."""
from __future__ import annotations

import pytest
import torch

from gesturelsm.reference.samplers import HOLDS_KNOWN, cosine_alphas_cumprod, diffusion, shortcut


class Recording:
    """A stand-in denoiser: records what it is given and predicts zeros (no speech keys, no guidance)."""

    def __init__(self):
        self.seen: list[tuple[torch.Tensor, torch.Tensor]] = []

    def speech_kv(self, speech, fold):
        return []

    def null_kv(self, fold):
        return []

    def __call__(self, x, t, d, seed, kv):
        self.seen.append((x.clone(), t.clone()))
        return torch.full_like(x, 0.3)


@pytest.mark.parametrize("sampler", ["shortcut", "diffusion"])
def test_known_latents_are_noised_to_each_calls_time_and_held_in_the_result(sampler):
    torch.manual_seed(0)
    known, noise = torch.randn(1, 6, 8), torch.randn(1, 6, 8)
    mask = torch.zeros(1, 6, 8, dtype=torch.bool)
    mask[..., :3] = True                                           # the first 3 latent frames known
    model = Recording()
    steps = 4
    if sampler == "shortcut":
        out = shortcut(model, noise, None, None, steps, 1.0, hold=(known, mask))
        ts = torch.linspace(1e-8, 1 - 1e-8, steps + 1)
        noised = [ts[k] * known + (1 - ts[k]) * noise for k in range(steps)]
    else:
        out = diffusion(model, noise, None, None, steps, 1.0, hold=(known, mask))
        ac = cosine_alphas_cumprod(1000)
        noised = [ac[k] ** 0.5 * known + (1 - ac[k]) ** 0.5 * noise for k in (750, 500, 250, 0)]
    assert len(model.seen) == steps
    for (x, _), want in zip(model.seen, noised):
        assert torch.allclose(x[..., :3], want[..., :3], atol=1e-6)
    assert not torch.allclose(model.seen[-1][0][..., 3:], noised[-1][..., 3:])     # the rest: the sampler's
    assert torch.equal(out[..., :3], known[..., :3]) and not torch.equal(out[..., 3:], known[..., 3:])
    assert sampler in HOLDS_KNOWN and "meanflow" not in HOLDS_KNOWN
