"""The few rotation operations grounding needs, on numpy float64 arrays batched over any leading dims (matrices act
on column vectors; axis-angle as in motion/rotations.py, whose conventions these follow in numpy)."""
from __future__ import annotations

import numpy as np
import torch

from ..motion.rotations import matrix_to_axis_angle

EPS = 1e-9


def _skew(v: np.ndarray) -> np.ndarray:
    """(..., 3) -> (..., 3, 3) the cross-product matrix [v]x."""
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    o = np.zeros_like(x)
    return np.stack([o, -z, y, z, o, -x, -y, x, o], -1).reshape(v.shape + (3,))


def exp(aa: np.ndarray) -> np.ndarray:
    """(..., 3) axis-angle -> (..., 3, 3), Rodrigues with its series near angle 0."""
    aa = np.asarray(aa, np.float64)
    t2 = (aa * aa).sum(-1)[..., None, None]
    t = np.sqrt(t2)
    small = t2 < 1e-8
    a = np.where(small, 1 - t2 / 6, np.sin(t) / np.where(small, 1.0, t))
    b = np.where(small, 0.5 - t2 / 24, (1 - np.cos(t)) / np.where(small, 1.0, t2))
    K = _skew(aa)
    return np.eye(3) + a * K + b * (K @ K)


def log(R: np.ndarray) -> np.ndarray:
    """(..., 3, 3) -> (..., 3) axis-angle, angle in [0, pi] (the skew part; near pi motion/rotations.py's route)."""
    R = np.asarray(R, np.float64)
    v = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    cos2 = R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2] - 1                   # 2 cos(angle)
    sin2 = np.linalg.norm(v, axis=-1)                                       # 2 sin(angle)
    angle = np.arctan2(sin2, cos2)
    scale = np.where(sin2 > 1e-6, angle / np.maximum(sin2, 1e-12), 0.5 + angle * angle / 12)
    aa = v * scale[..., None]
    far = cos2 < -1.8
    if far.any():
        aa[far] = matrix_to_axis_angle(torch.from_numpy(np.ascontiguousarray(R[far]))).numpy()
    return aa


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
