"""The few rotation operations grounding needs, on numpy float64 arrays batched over any leading dims (matrices act
on column vectors; axis-angle as in motion/rotations.py, whose torch conversions these wrap)."""
from __future__ import annotations

import numpy as np
import torch

from ..motion.rotations import axis_angle_to_matrix, matrix_to_axis_angle

EPS = 1e-9


def exp(aa: np.ndarray) -> np.ndarray:
    """(..., 3) axis-angle -> (..., 3, 3)."""
    return axis_angle_to_matrix(torch.from_numpy(np.ascontiguousarray(aa, np.float64))).numpy()


def log(R: np.ndarray) -> np.ndarray:
    """(..., 3, 3) -> (..., 3) axis-angle, angle in [0, pi]."""
    return matrix_to_axis_angle(torch.from_numpy(np.ascontiguousarray(R, np.float64))).numpy()


def normalize(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), EPS)


def between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(..., 3, 3) the smallest rotation taking direction a to direction b (both (..., 3), any length)."""
    a, b = normalize(a), normalize(b)
    axis = np.cross(a, b)
    s = np.linalg.norm(axis, axis=-1, keepdims=True)
    c = np.clip((a * b).sum(-1, keepdims=True), -1.0, 1.0)
    return exp(axis / np.maximum(s, EPS) * np.arctan2(s, c))


def about(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotation by `angle` (...) radians about the unit `axis` (..., 3)."""
    return exp(axis * np.asarray(angle)[..., None])


def slerp(R0: np.ndarray, R1: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(..., 3, 3) from R0 (w = 0) to R1 (w = 1) along the shortest arc."""
    return R0 @ exp(log(np.swapaxes(R0, -1, -2) @ R1) * np.asarray(w)[..., None])


def yaw_only(R: np.ndarray, forward: np.ndarray) -> np.ndarray:
    """(..., 3, 3) the rotation about the vertical (y) axis that turns the horizontal `forward` (3,) the way R turns
    it, seen from above: R with its tilt (pitch and roll) removed."""
    f = R @ forward
    yaw = np.arctan2(f[..., 0], f[..., 2]) - np.arctan2(forward[0], forward[2])
    return about(np.broadcast_to(np.array([0.0, 1.0, 0.0]), f.shape), yaw)
