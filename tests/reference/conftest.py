"""Converted authors' checkpoints at reduced size, built once per session from the recorded fixture."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from gesturelsm.reference.config import REGION_DIMS, RVQConfig
from gesturelsm.reference.convert import generator_from_state, save_generator, save_rvqs
from gesturelsm.reference.rvq import ReferenceRVQ
from gesturelsm.reference.released_files import load_state

FIX = Path(__file__).parent / "fixtures"


@pytest.fixture(scope="session")
def ckpt_dir(tmp_path_factory) -> Path:
    """What `gesturelsm import-reference` writes, at reduced size (RVQ width 8, code dim 128 to fit the fixture
    generator): reference_rvq.safetensors and reference_{shortcut,meanflow}.safetensors."""
    d = tmp_path_factory.mktemp("authors")
    torch.manual_seed(0)
    rvqs = {r: ReferenceRVQ(RVQConfig(input_dim=n, width=8, num_codes=16)).eval() for r, n in REGION_DIMS.items()}
    for m in rvqs.values():
        m.codes.normal_()
    rng = np.random.default_rng(0)
    stats = {"mean": rng.normal(size=330) * 0.1, "std": np.full(330, 0.2), "trans_mean": np.zeros(3),
             "trans_std": np.ones(3)}
    save_rvqs(d / "reference_rvq.safetensors", rvqs, stats, "test")
    state = load_state(FIX / "generator.bin", ("model_state",))
    for method in ("shortcut", "meanflow"):
        save_generator(d / f"reference_{method}.safetensors", generator_from_state(state, method), {"hello": 4}, "test")
    return d
