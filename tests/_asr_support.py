"""eSpeak NG speech of known sentences for the speech recognition tests (tests/asr, tests/generator)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from gesturelsm.align import tts

SR = 16_000
BEAT2 = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "beat2"
ENGLISH = "yesterday my sister walked to the market and bought fresh bread apples and a bottle of milk"
GERMAN = ("guten morgen heute möchte ich ihnen erzählen wie wir im letzten sommer mit dem fahrrad durch die "
          "berge gefahren sind")


def speak(text: str, voice: str) -> np.ndarray:
    """eSpeak NG speech of `text` at 16 kHz with 0.5 s of faint noise on each side, (N,) float32."""
    from gesturelsm.audio import resample

    syn = tts.synthesize(text.split(), (voice,), 160)[0]
    y = resample(syn.audio, syn.sr, SR)
    pad = np.zeros(SR // 2, np.float32)
    y = np.concatenate([pad, y, pad])
    return (y + 3e-4 * np.random.default_rng(0).standard_normal(len(y))).astype(np.float32)


def asr_available() -> bool:
    from gesturelsm.asr import available

    return available() and tts.available()
