"""Shared fixtures. Real BEAT2 data lives in ../shared beside the repository (never copied into it)."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from _support import build_tiny_assets

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


TEXTGRID = '''File type = "ooTextFile"
Object class = "TextGrid"

xmin = 0
xmax = {dur}
tiers? <exists>
size = 1
item []:
    item [1]:
        class = "IntervalTier"
        name = "words"
        xmin = 0
        xmax = {dur}
        intervals: size = 3
        intervals [1]:
            xmin = 0
            xmax = 0.5
            text = ""
        intervals [2]:
            xmin = 0.5
            xmax = 1.0
            text = "hello"
        intervals [3]:
            xmin = 1.0
            xmax = {dur}
            text = "world"
'''


def make_take(root: Path, name: str, frames: int, sr: int = 16000, dtype: str = "float32",
              audio_extra_s: float = 0.5, textgrid: bool = True):
    """A synthetic take: random poses, a 220 Hz tone, and a two-word TextGrid."""
    import soundfile as sf

    from gesturelsm.motion import MotionSequence

    rng = np.random.default_rng(frames)
    seq = MotionSequence(rng.normal(scale=0.3, size=(frames, 165)), np.tile([0, 1.3, 0], (frames, 1)),
                         rng.normal(size=(frames, 100)))
    seq.save(root / "smplxflame_30" / f"{name}.npz")
    n = int((frames / 30 + audio_extra_s) * sr)
    y = (0.3 * np.sin(np.arange(n) / sr * 2 * np.pi * 220)).astype(np.float32)
    (root / "wave16k").mkdir(parents=True, exist_ok=True)
    if dtype == "int16":
        sf.write(root / "wave16k" / f"{name}.wav", (y * 32767).astype(np.int16), sr, subtype="PCM_16")
    else:
        sf.write(root / "wave16k" / f"{name}.wav", y, sr, subtype="FLOAT")
    if textgrid:
        (root / "textgrid").mkdir(parents=True, exist_ok=True)
        (root / "textgrid" / f"{name}.TextGrid").write_text(TEXTGRID.format(dur=frames / 30))
    return seq


@pytest.fixture
def beat2_maker():
    """make(root, name, frames, ...) writes one synthetic take in BEAT2 layout (see make_take)."""
    return make_take


# A tiny but complete set of checkpoints (4 tokenizers + 3 generators) built from synthetic motion, so the whole
# pipeline runs in tests without ../shared or the shipped assets (tests/app and tests/evaluation build their own).
@pytest.fixture(scope="session")
def tiny_assets(tmp_path_factory) -> Path:
    return build_tiny_assets(tmp_path_factory.mktemp("assets"), steps=40, batch_size=8, warmup=5)


@pytest.fixture(scope="session")
def tiny_pipeline(tiny_assets):
    from gesturelsm.pipeline import GesturePipeline

    return GesturePipeline.from_pretrained(tiny_assets)


# Fixtures whose tests leave the fast tier (`make test-fast`, `-m "not slow and not browser"`): each costs tens of
# seconds on 2 cores or reads the real data; `make test` runs them all.
HEAVY_FIXTURES = {
    "app_url": "serves the web app",
    "service": "the web app's request service over trained checkpoints (renders videos)",
    "shipped_pipe": "streams through the shipped network",
    "recognizer": "loads Whisper",
    "beat2_root": "reads the real BEAT2 take",
    "beat2": "reads the real BEAT2 take",
    "eval_assets": "trains models for the evaluation runners",
}


def pytest_collection_modifyitems(config, items):
    for item in items:
        if HEAVY_FIXTURES.keys() & set(getattr(item, "fixturenames", ())):
            item.add_marker(pytest.mark.slow)
