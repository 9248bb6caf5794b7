"""Does motion follow *its* speech? Each test scores the motion against its own speech and against the same speech
moved in time (circular shifts inside the scored span: the same statistics, the wrong timing). Motion that ignores
the speech scores the same either way on average (gain 0); z = gain / spread over the shifts.

- beat_timing: beat consistency (metrics.beat) with the speech's onsets vs shifted onsets;
- energy_following: correlation of the upper body's speed with the speech's loudness (RMS per frame), both
  smoothed over ~1 s, vs the loudness shifted by >= 2 s.

Each needs speech long enough to shift (`min_seconds`): beat timing more than 6 s, since beat consistency ignores
the first and last 2 s (IGNORE_FRAMES: no motion beat is detected there, as in the paper's metric) and the beats
must move by at least 1 s either way inside the 2 s left; loudness following more than 4 s (2 s either way).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..constants import FPS, SAMPLE_RATE
from ..errors import InputError
from .beat import IGNORE_FRAMES, joint_beats, joint_speed, score_beats
from ..motion.regions import REGIONS

UPPER = REGIONS["upper"].joints
BEAT_MIN_SHIFT = 1.0            # s: the smallest shift of the beats (BC's tolerance is 0.3 s)
LOUDNESS_MIN_SHIFT = 2.0        # s: the smallest shift of the loudness (both are smoothed over 1 s)


def beat_timing_frames(fps: int = FPS, min_shift: float = BEAT_MIN_SHIFT) -> int:
    """The fewest frames `beat_timing` scores: the span left after IGNORE_FRAMES at each end must hold a shift of
    `min_shift` either way."""
    return 2 * IGNORE_FRAMES + 1 + math.ceil(2 * min_shift * fps)


def energy_following_frames(fps: int = FPS, min_shift: float = LOUDNESS_MIN_SHIFT) -> int:
    """The fewest frames `energy_following` scores: a shift of `min_shift` either way."""
    return 2 * round(min_shift * fps) + 1


def min_seconds(frames: int, fps: int = FPS) -> float:
    """Speech length, rounded up to a tenth of a second, that gives at least `frames` motion frames."""
    return math.ceil(frames / fps * 10 - 1e-9) / 10


@dataclass(frozen=True)
class ShiftTest:
    own: float             # score with the speech as it is
    shifted_mean: float    # mean score with the speech shifted in time
    shifted_std: float     # spread of that over the shifts
    num_shifts: int

    @property
    def gain(self) -> float:
        """> 0: the motion fits its own speech better than the same speech at the wrong time."""
        return self.own - self.shifted_mean

    @property
    def z(self) -> float:
        return self.gain / max(self.shifted_std, 1e-12)


def beat_timing(joints: np.ndarray, beats: np.ndarray, fps: int = FPS, mean_speed: np.ndarray | None = None,
                min_shift: float = BEAT_MIN_SHIFT, step: float = 0.25, joint_ids: tuple[int, ...] = UPPER) -> ShiftTest:
    """BC with the audio beats (s) as they are vs circularly shifted by `min_shift` .. span - `min_shift` seconds
    (every `step`) within the span where motion beats can occur (IGNORE_FRAMES from either end); the own score
    counts the beats inside that span too. No beat leaves the span, so the shifted scores are a fair baseline.
    (Shifting by a fixed +-s instead moves some beats into the first or last 2 s, where no motion beat is ever
    detected and they score ~0: that lowers the baseline for any motion.)"""
    T = joints.shape[0]
    lo, hi = IGNORE_FRAMES / fps, (T - 1 - IGNORE_FRAMES) / fps
    span = hi - lo
    a = np.asarray(beats, float)
    a = a[(a >= lo) & (a < hi)]
    shifts = np.arange(min_shift, span - min_shift + 1e-9, step)
    if len(a) == 0 or len(shifts) == 0:
        raise InputError(f"{T / fps:.1f} s of motion (with {len(a)} beats) is too short to shift beats by "
                         f">= {min_shift} s inside the scored span")
    m = joint_beats(joints, fps, mean_speed, joint_ids)
    null = np.array([score_beats(lo + (a - lo + s) % span, m) for s in shifts])
    return ShiftTest(score_beats(a, m), float(null.mean()), float(null.std()), len(shifts))


def loudness(audio: np.ndarray, num_frames: int, sr: int = SAMPLE_RATE, fps: int = FPS) -> np.ndarray:
    """(N,) -> (num_frames,) RMS of the samples of each frame (0 past the end of the audio)."""
    hop = sr / fps
    edges = np.round(np.arange(num_frames + 1) * hop).astype(int)
    sq = np.concatenate([[0.0], np.cumsum(np.asarray(audio, np.float64) ** 2)])
    edges = np.minimum(edges, len(audio))
    n = np.maximum(np.diff(edges), 1)
    return np.sqrt((sq[edges[1:]] - sq[edges[:-1]]) / n)


def _smooth(x: np.ndarray, w: int) -> np.ndarray:
    return np.convolve(x, np.ones(w) / w, mode="same") if w > 1 else x


def _corr(x: np.ndarray, y: np.ndarray) -> float:
    x, y = x - x.mean(), y - y.mean()
    return float((x * y).sum() / max(np.sqrt((x * x).sum() * (y * y).sum()), 1e-12))


def energy_following(joints: np.ndarray, audio: np.ndarray, sr: int = SAMPLE_RATE, fps: int = FPS,
                     smooth_s: float = 1.0,
                     min_shift: float = LOUDNESS_MIN_SHIFT, step: float = 0.25,
                     joint_ids: tuple[int, ...] = UPPER) -> ShiftTest:
    """Pearson correlation of upper-body speed with speech loudness, both averaged over `smooth_s`, vs the same with
    the loudness circularly shifted by `min_shift` .. length - `min_shift` seconds (every `step`)."""
    speed = joint_speed(joints, fps)[:, list(joint_ids)].mean(1)                 # (T-1,)
    n = len(speed)
    shifts = np.arange(round(min_shift * fps), n - round(min_shift * fps) + 1, max(1, round(step * fps)))
    if len(shifts) == 0:
        raise InputError(f"{n / fps:.1f} s of motion is too short to shift the speech by >= {min_shift} s")
    w = max(1, round(smooth_s * fps))
    m, e = _smooth(speed, w), _smooth(loudness(audio, n, sr, fps), w)
    null = np.array([_corr(m, np.roll(e, int(s))) for s in shifts])
    return ShiftTest(_corr(m, e), float(null.mean()), float(null.std()), len(shifts))
