"""Batched 3-vector helpers for retargeting (numpy, float64): unit vectors, shortest rotations, frames."""
from __future__ import annotations

import numpy as np

from ..motion.rotations import rotation_between_np as rotation_between   # noqa: F401 (retargeting's name for it)

def unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)



def frame(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(..., 3) x2 -> (..., 3, 3) orthonormal frame with columns a, b orthogonalised against a, a x b."""
    x = unit(a)
    y = unit(b - (b * x).sum(-1, keepdims=True) * x)
    return np.stack([x, y, np.cross(x, y)], -1)
