"""A tiny but complete set of checkpoints (4 tokenizers + 3 generators) built from synthetic motion, so the
whole pipeline runs in tests without ../shared or the shipped assets."""
from __future__ import annotations

from pathlib import Path

import pytest

from _support import build_tiny_assets


@pytest.fixture(scope="session")
def tiny_assets(tmp_path_factory) -> Path:
    return build_tiny_assets(tmp_path_factory.mktemp("assets"), steps=40, batch_size=8, warmup=5)


@pytest.fixture(scope="session")
def tiny_pipeline(tiny_assets):
    from gesturelsm.pipeline import GesturePipeline

    return GesturePipeline.from_pretrained(tiny_assets)
