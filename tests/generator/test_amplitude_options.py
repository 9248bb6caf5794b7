"""Inference options of the amplitude study (evaluation/amplitude.py): guidance interval and first-window seed."""
from __future__ import annotations

import numpy as np
import torch

from gesturelsm.evaluation.amplitude import sampling_options


def _poses(pipe, cfg: float, **opts) -> np.ndarray:
    y = np.random.default_rng(0).normal(scale=0.1, size=16000 * 2).astype(np.float32)
    with sampling_options(pipe.generators["gesturelsm"], **opts):
        return pipe.generate(y, 16000, steps=4, cfg=cfg, seed=1, transcribe=False, output="raw").motion.poses


def test_guidance_interval_limits(tiny_pipeline):
    full = _poses(tiny_pipeline, 3.0)
    assert np.allclose(_poses(tiny_pipeline, 3.0, guidance_interval=(0.0, 1.0)), full, atol=1e-6)
    cond = _poses(tiny_pipeline, 1.0)
    assert np.allclose(_poses(tiny_pipeline, 3.0, guidance_interval=(2.0, 3.0)), cond, atol=1e-6)   # never guided
    half = _poses(tiny_pipeline, 3.0, guidance_interval=(0.5, 1.0))
    assert not np.allclose(half, full, atol=1e-4) and not np.allclose(half, cond, atol=1e-4)


def test_seed_option_changes_the_start_and_is_undone(tiny_pipeline):
    model = tiny_pipeline.generators["gesturelsm"]
    before = model.neutral_seed.clone()
    base = _poses(tiny_pipeline, 2.0)
    other = _poses(tiny_pipeline, 2.0, seed_latents=torch.ones_like(before))
    assert not np.allclose(other[:8], base[:8], atol=1e-4)                 # the first frames follow the seed
    assert torch.equal(model.neutral_seed, before) and "bind" not in vars(model)
    assert np.allclose(_poses(tiny_pipeline, 2.0), base, atol=1e-6)        # restored afterwards
