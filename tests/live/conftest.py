"""The shipped checkpoints (assets/) for live-mode tests: the streaming logic is checked on the real network."""
from __future__ import annotations

import numpy as np
import pytest
import torch


@pytest.fixture(scope="session")
def shipped_pipe():
    from gesturelsm.pipeline import ASSETS, GesturePipeline

    if not (ASSETS / "generator" / "gesturelsm.safetensors").exists():
        pytest.skip("shipped checkpoints not found in assets/")
    torch.set_num_threads(1)
    from gesturelsm.features.audio import audio_channels

    pipe = GesturePipeline.from_pretrained(methods=["gesturelsm"], warm_up=False)
    audio_channels(np.random.default_rng(0).normal(scale=0.1, size=16000).astype(np.float32))  # librosa's JIT, once
    return pipe
