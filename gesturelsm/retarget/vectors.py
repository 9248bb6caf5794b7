"""Batched 3-vector helpers for retargeting (numpy, float64): unit vectors, shortest rotations, frames."""
from __future__ import annotations

import numpy as np


def unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(..., 3) unit vectors a, b -> (..., 3, 3) the shortest rotation R with R a = b (Rodrigues). For
    opposite vectors, a half turn about an axis perpendicular to a."""
    a, b = np.broadcast_arrays(unit(a), unit(b))
    v = np.cross(a, b)
    c = (a * b).sum(-1)
    opposite = c < -1 + 1e-9
    if np.any(opposite):
        alt = np.where(np.abs(a[..., :1]) < 0.9, np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))
        perp = unit(np.cross(a, alt))
        v = np.where(opposite[..., None], perp, v)
    K = np.zeros(v.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    f = np.where(opposite, 0.0, 1.0 / np.maximum(1.0 + c, 1e-12))
    R = np.eye(3) + K + (K @ K) * f[..., None, None]
    # half turn: R = 2 perp perp^T - I
    if np.any(opposite):
        half = 2 * v[..., :, None] * v[..., None, :] - np.eye(3)
        R = np.where(opposite[..., None, None], half, R)
    return R


def frame(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(..., 3) x2 -> (..., 3, 3) orthonormal frame with columns a, b orthogonalised against a, a x b."""
    x = unit(a)
    y = unit(b - (b * x).sum(-1, keepdims=True) * x)
    return np.stack([x, y, np.cross(x, y)], -1)
