"""Tiny checkpoints and a tiny BEAT2-layout folder, built in the test session (no ../shared, no assets/)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
import torch

from _support import speech_like, synthetic_motion


@pytest.fixture(scope="session")
def eval_assets(tmp_path_factory) -> Path:
    from gesturelsm.generator.data import build_take
    from gesturelsm.generator.train import GenTrainConfig, train_generator
    from gesturelsm.motion import REGIONS, Normalizer
    from gesturelsm.motion.regions import GENERATED_REGIONS
    from gesturelsm.tokenizer import RVQVAE, preset

    torch.manual_seed(0)
    root = tmp_path_factory.mktemp("eval_assets")
    motion = synthetic_motion()
    feats = motion.to_features()
    toks = {}
    for r in GENERATED_REGIONS:
        cols = list(REGIONS[r].columns)
        m = RVQVAE(preset("tiny", len(cols)), r, Normalizer.fit(feats[:, cols]))
        m.train()
        m(m.normalizer.normalize(feats[:256, cols])[None])
        toks[r] = m.eval()
        m.save(root / "tokenizer" / f"{r}.safetensors", half=True)
    take = build_take("synthetic", feats, speech_like(motion.duration), None, toks, None)
    for method in ("gesturelsm", "rectified_flow", "ddim"):
        tc = GenTrainConfig(method=method, preset="tiny", steps=5, batch_size=4, lr=2e-3, warmup=2,
                            eval_every=1000, save_every=1000)
        gen = train_generator([take], [], toks, tc, root / "runs" / f"{method}.safetensors", log=lambda *_: None)
        gen.save(root / "generator" / f"{method}.safetensors", half=True)
    return root


@pytest.fixture(scope="session")
def tiny_beat2(tmp_path_factory) -> Path:
    """One motion take (10 s, speech-like audio) and one audio-only take (6 s), BEAT2 layout, no split file."""
    root = tmp_path_factory.mktemp("beat2")
    seq = synthetic_motion(frames=300, seed=3)
    seq.save(root / "smplxflame_30" / "2_test_0_1_1.npz")
    (root / "wave16k").mkdir()
    sf.write(root / "wave16k" / "2_test_0_1_1.wav", speech_like(10.0, seed=1), 16000, subtype="FLOAT")
    sf.write(root / "wave16k" / "2_test_0_2_2.wav", speech_like(6.0, seed=2), 16000, subtype="FLOAT")
    return root
