"""Beat consistency (BC) between speech and motion, as the reference evaluation defines it
(docs/AUTHORS-CODE.md, beat consistency).

- Audio beats: librosa onsets of the 16 kHz speech (hop 512), in seconds; beats in the first 2 s skipped.
- Motion beats, per upper-body joint: joint speed (m/s, from positions at 30 fps) divided by that joint's
  mean speed; its local minima of order 7 (a minimum over +-7 frames) where the normalised speed is still
  above 0.3 (pauses within motion, not rest); the first and last 60 frames are ignored.
- Score per joint: mean over audio beats of exp(-d^2 / (2 * 0.3^2)), d = seconds to the nearest motion beat;
  BC = mean over the upper-body joints. Ground truth of the paper's test set scores 0.703; closer to the
  ground truth's BC is better, not simply higher.
"""
from __future__ import annotations

import numpy as np
from scipy.signal import argrelextrema

from ..constants import FPS, SAMPLE_RATE
from ..motion.regions import REGIONS

SIGMA = 0.3
ORDER = 7
THRESHOLD = 0.3
IGNORE_FRAMES = 60
SKIP_AUDIO_S = 2.0


def audio_beats(audio: np.ndarray, sr: int = SAMPLE_RATE, hop: int = 512, skip_s: float = SKIP_AUDIO_S) -> np.ndarray:
    """Onset times in seconds (librosa), those before `skip_s` dropped."""
    import librosa

    t = librosa.onset.onset_detect(y=audio.astype(np.float32), sr=sr, hop_length=hop, units="time")
    return t[t >= skip_s]


def joint_speed(joints: np.ndarray, fps: int = FPS) -> np.ndarray:
    """(T, J, 3) positions (m) -> (T-1, J) speeds (m/s)."""
    return np.linalg.norm(np.diff(joints, axis=0), axis=-1) * fps


def motion_beats(speed: np.ndarray, fps: int = FPS, order: int = ORDER, threshold: float = THRESHOLD,
                 ignore: int = IGNORE_FRAMES) -> np.ndarray:
    """(T,) normalised speed of one joint -> beat times (s)."""
    idx = argrelextrema(speed, np.less, order=order)[0]
    idx = idx[(speed[idx] > threshold) & (idx >= ignore) & (idx < len(speed) - ignore)]
    return idx / fps


def beat_score(a_beats: np.ndarray, m_beats: np.ndarray, sigma: float = SIGMA) -> float:
    if len(a_beats) == 0:
        return float("nan")
    if len(m_beats) == 0:
        return 0.0
    d = np.abs(a_beats[:, None] - m_beats[None, :]).min(axis=1)
    return float(np.exp(-d ** 2 / (2 * sigma ** 2)).mean())


def beat_consistency(joints: np.ndarray, audio: np.ndarray | None = None, sr: int = SAMPLE_RATE, fps: int = FPS,
                     mean_speed: np.ndarray | None = None, beats: np.ndarray | None = None,
                     joint_ids: tuple[int, ...] = REGIONS["upper"].joints) -> float:
    """joints: (T, 55, 3) positions in metres. `mean_speed` (55,) m/s normalises speeds (BEAT2's
    mean_vel_smplxflame_30.npy); None uses this motion's own per-joint mean speed. `beats` overrides the
    audio onsets (seconds)."""
    a = audio_beats(audio, sr) if beats is None else np.asarray(beats, float)
    a = a[a < joints.shape[0] / fps]
    return score_beats(a, joint_beats(joints, fps, mean_speed, joint_ids))


def joint_beats(joints: np.ndarray, fps: int = FPS, mean_speed: np.ndarray | None = None,
                joint_ids: tuple[int, ...] = REGIONS["upper"].joints) -> list[np.ndarray]:
    """(T, 55, 3) -> motion beat times (s) of each joint in `joint_ids` (speeds normalised as in BC)."""
    speed = joint_speed(joints, fps)[:, list(joint_ids)]                         # (T-1, J)
    ref = (np.asarray(mean_speed)[list(joint_ids)] if mean_speed is not None else speed.mean(0))
    speed = speed / np.maximum(ref, 1e-6)
    return [motion_beats(speed[:, j], fps) for j in range(speed.shape[1])]


def score_beats(a_beats: np.ndarray, m_beats: list[np.ndarray]) -> float:
    return float(np.nanmean([beat_score(a_beats, m) for m in m_beats])) if len(a_beats) else float("nan")
