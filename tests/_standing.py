"""Standing motions on the built-in mannequin for the grounding tests of live streams and characters: the body on
y = 0 with its arms, head and face moving, a foot that slides, a foot that steps, a pelvis that sways; and SMPL-X
rest joints with other leg proportions (a character's)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from gesturelsm.evaluation.motion_stats import stats_body
from gesturelsm.motion import MotionSequence
from gesturelsm.motion.skeleton import JOINT_INDEX

FPS = 30
LEG_JOINTS = (0, 1, 2, 4, 5, 7, 8, 10, 11)                 # pelvis, hips, knees, ankles, feet
CHANGED_COLUMNS = [3 * j + k for j in (1, 2, 4, 5, 7, 8) for k in range(3)]
KEPT_COLUMNS = [c for c in range(165) if c not in CHANGED_COLUMNS]


def standing(seconds: float = 12.0, seed: int = 0) -> MotionSequence:
    """The mannequin standing on y = 0, its arms, head and face moving (slow random sines)."""
    body = stats_body()
    T = int(seconds * FPS)
    t = np.arange(T)[:, None] / FPS
    rng = np.random.default_rng(seed)
    poses = np.zeros((T, 165))
    cols = [3 * j + k for j in range(55) if j not in LEG_JOINTS for k in range(3)]
    poses[:, cols] = 0.3 * np.sin(2 * np.pi * rng.uniform(0.2, 1.0, len(cols)) * t + rng.uniform(0, 6, len(cols)))
    trans = np.tile([0.0, -float(body.rest_vertices()[:, 1].min()), 0.0], (T, 1))
    return MotionSequence(poses, trans, 0.5 * np.sin(t * rng.uniform(0.5, 2, (1, 100))))


def sliding_left_foot(seq: MotionSequence) -> MotionSequence:
    """The left leg swings sideways about the hip: the left foot slides over the floor (+-10 cm, 16 cm/s at most)."""
    t = np.arange(seq.num_frames) / FPS
    poses = seq.poses.copy()
    poses[:, 3 * 1 + 2] = 0.12 * np.sin(2 * np.pi * 0.25 * t)
    return replace(seq, poses=poses)


def stepping(seq: MotionSequence, side: str = "right", every: float = 2.0, length: float = 0.6,
             offset: float = 0.0) -> MotionSequence:
    """A foot lifts (hip and knee flex, the foot level) and comes down on the same spot every `every` seconds."""
    hip, knee, ankle = (JOINT_INDEX[f"{side}_{n}"] for n in ("hip", "knee", "ankle"))
    t = np.arange(seq.num_frames) / FPS
    phase = ((t - offset) % every) / length
    bump = np.where((phase < 1) & (t >= offset), np.sin(np.pi * np.clip(phase, 0, 1)) ** 2, 0.0)
    poses = seq.poses.copy()
    poses[:, 3 * hip] = -0.5 * bump
    poses[:, 3 * knee] = 1.0 * bump
    poses[:, 3 * ankle] = -0.5 * bump
    return replace(seq, poses=poses)


def swaying(seq: MotionSequence) -> MotionSequence:
    """The pelvis shifts its weight: sideways +-5 cm, forward +-3 cm, down and up 4 cm."""
    t = np.arange(seq.num_frames) / FPS
    trans = seq.trans.copy()
    trans[:, 0] += 0.05 * np.sin(2 * np.pi * 0.3 * t)
    trans[:, 1] += 0.02 * np.sin(2 * np.pi * 0.5 * t) - 0.02
    trans[:, 2] += 0.03 * np.sin(2 * np.pi * 0.2 * t)
    return replace(seq, trans=trans.astype(seq.trans.dtype))


def joints(seq: MotionSequence) -> np.ndarray:
    """(T, 55, 3) world joints on the mannequin."""
    return stats_body().joints(seq.poses, seq.trans, betas=seq.betas).astype(np.float64)


def other_legs(J: np.ndarray, thigh: float = 0.85, shin: float = 1.3, hips: float = 1.25) -> np.ndarray:
    """SMPL-X rest joints (55, 3) with a character's legs: thighs `thigh` and shins `shin` times as long, the hips
    `hips` times as wide (both legs alike, so the rest pose still stands on both feet)."""
    J = np.asarray(J, np.float64).copy()
    for s in ("left", "right"):
        h, k, a, f = (JOINT_INDEX[f"{s}_{n}"] for n in ("hip", "knee", "ankle", "foot"))
        J[[h, k, a, f], 0] += J[h, 0] * (hips - 1)
        J[[k, a, f]] += (J[k] - J[h]) * (thigh - 1)
        J[[a, f]] += (J[a] - J[k]) * (shin - 1)
    return J


def segments(mask: np.ndarray) -> list[tuple[int, int]]:
    """[(start, stop)] of the True runs of a (T,) mask."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    d = np.flatnonzero(np.diff(m.astype(int)))
    return list(zip(d[::2].tolist(), d[1::2].tolist()))
