"""A tiny but complete set of checkpoints (4 tokenizers + 3 generators) built from synthetic motion, so the
whole pipeline runs in tests without ../shared or the shipped assets."""
from __future__ import annotations

from pathlib import Path

import pytest
import torch

from gesturelsm.generator.data import build_take
from gesturelsm.generator.train import GenTrainConfig, train_generator
from gesturelsm.motion import REGIONS, Normalizer
from gesturelsm.motion.regions import GENERATED_REGIONS
from gesturelsm.tokenizer import RVQVAE, preset

from _support import speech_like, synthetic_motion


@pytest.fixture(scope="session")
def tiny_assets(tmp_path_factory) -> Path:
    torch.manual_seed(0)
    root = tmp_path_factory.mktemp("assets")
    motion = synthetic_motion()
    feats = motion.to_features()
    toks = {}
    for r in GENERATED_REGIONS:
        cols = list(REGIONS[r].columns)
        m = RVQVAE(preset("tiny", len(cols)), r, Normalizer.fit(feats[:, cols]))
        m.train()
        m(m.normalizer.normalize(feats[:256, cols])[None])  # initialise codebooks from data
        toks[r] = m.eval()
        m.save(root / "tokenizer" / f"{r}.safetensors", half=True)
    take = build_take("synthetic", feats, speech_like(motion.duration), None, toks, None)
    for method in ("gesturelsm", "rectified_flow", "ddim"):
        tc = GenTrainConfig(method=method, preset="tiny", steps=40, batch_size=8, lr=2e-3, warmup=5,
                            eval_every=1000, save_every=1000)
        gen = train_generator([take], [], toks, tc, root / "runs" / f"{method}.safetensors", log=lambda *_: None)
        gen.save(root / "generator" / f"{method}.safetensors", half=True)
    return root


@pytest.fixture(scope="session")
def tiny_pipeline(tiny_assets):
    from gesturelsm.pipeline import GesturePipeline

    return GesturePipeline.from_pretrained(tiny_assets)
