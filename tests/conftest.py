"""Shared fixtures. Real BEAT2 data lives in ../shared beside the repository (never copied into it)."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("GESTURELSM_SHARED", REPO.parent / "shared"))
BEAT2 = SHARED / "data" / "beat2"
REAL_TAKE = "2_scott_0_1_1"


@pytest.fixture(scope="session")
def beat2_root() -> Path:
    if not (BEAT2 / "smplxflame_30" / f"{REAL_TAKE}.npz").exists():
        pytest.skip(f"real BEAT2 sample not found at {BEAT2} (../shared beside the repo)")
    return BEAT2


@pytest.fixture(scope="session")
def real_motion(beat2_root: Path):
    from gesturelsm.motion import MotionSequence

    return MotionSequence.load(beat2_root / "smplxflame_30" / f"{REAL_TAKE}.npz")
