"""The session's tiny checkpoints (tests/conftest.py) and a tiny BEAT2-layout folder, built in the test session
(no ../shared, no assets/)."""
from __future__ import annotations

from pathlib import Path

import pytest
import soundfile as sf

from _support import speech_like, synthetic_motion


@pytest.fixture(scope="session")
def eval_assets(tiny_assets) -> Path:
    return tiny_assets


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
