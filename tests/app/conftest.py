"""Fixtures for the web app tests: the session's tiny checkpoints (tests/conftest.py), a GestureService over them,
and the app served in this process on a free local port."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

os.environ["GRADIO_ANALYTICS_ENABLED"] = "False"
os.environ["HF_HUB_DISABLE_TELEMETRY"] = "1"


@pytest.fixture(scope="session")
def app_assets(tiny_assets) -> Path:
    return tiny_assets


@pytest.fixture(scope="session")
def beat2_dir(tmp_path_factory) -> Path:
    """A BEAT2-layout folder with one 2 s take (motion, a tone as speech, TextGrid)."""
    import soundfile as sf

    from gesturelsm.motion import MotionSequence

    from _support import speech_like, synthetic_motion

    root = tmp_path_factory.mktemp("beat2")
    synthetic_motion(frames=60, seed=3).save(root / "smplxflame_30" / "2_scott_0_9_9.npz")
    (root / "wave16k").mkdir()
    sf.write(root / "wave16k" / "2_scott_0_9_9.wav", speech_like(2.0, seed=5)[::-1].copy(), 16000)
    assert isinstance(MotionSequence.load(root / "smplxflame_30" / "2_scott_0_9_9.npz"), MotionSequence)
    return root


@pytest.fixture(scope="session")
def service(app_assets, beat2_dir, tmp_path_factory):
    from gesturelsm.serve.request import ServiceSettings
    from gesturelsm.serve.service import GestureService

    settings = ServiceSettings(checkpoints=str(app_assets), beat2=str(beat2_dir), max_seconds=20,
                               workdir=str(tmp_path_factory.mktemp("app_work")))
    return GestureService.from_settings(settings)


@pytest.fixture(scope="session")
def speech_wav(tmp_path_factory) -> Path:
    """2 s of speech-like sound as a 44.1 kHz stereo wav (the app resamples)."""
    import soundfile as sf

    from _support import speech_like

    y = speech_like(2.0, sr=44100)
    path = tmp_path_factory.mktemp("speech") / "speech.wav"
    sf.write(path, np.stack([y, y], 1), 44100)
    return path


@pytest.fixture(scope="session")
def app_url(service):
    """The app served from this process (as `python -m app` serves it) at a local URL."""
    from _support import served

    with served(service) as url:
        yield url

