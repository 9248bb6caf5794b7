"""Helpers shared by tests (importable because pytest puts tests/ on sys.path)."""
from __future__ import annotations

import numpy as np

from gesturelsm.motion import MotionSequence


def synthetic_motion(frames: int = 480, seed: int = 0) -> MotionSequence:
    """Smooth random motion: sums of slow sines per pose channel."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames)[:, None] / 30
    poses = 0.3 * np.sin(2 * np.pi * rng.uniform(0.2, 1.5, (1, 165)) * t + rng.uniform(0, 6, (1, 165)))
    trans = np.tile([0.0, 1.3, 0.0], (frames, 1))
    return MotionSequence(poses, trans, 0.5 * np.sin(t * rng.uniform(0.5, 2, (1, 100))))


def speech_like(seconds: float, sr: int = 16000, seed: int = 0) -> np.ndarray:
    """Bursts of noise-modulated tones (syllable-like envelopes), deterministic."""
    rng = np.random.default_rng(seed)
    n = int(seconds * sr)
    t = np.arange(n) / sr
    env = np.clip(np.sin(2 * np.pi * 3.1 * t), 0, None) ** 2 * (rng.random(n) * 0.2 + 0.8)
    return (0.3 * env * np.sin(2 * np.pi * 180 * t * (1 + 0.1 * np.sin(2 * np.pi * 0.5 * t)))).astype(np.float32)
