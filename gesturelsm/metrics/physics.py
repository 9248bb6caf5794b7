"""Physical plausibility: jitter, on joint positions (T, 55, 3) in metres, 30 fps, y up.

- `jitter`: mean magnitude of the third derivative of position (jerk, m/s^3) over frames and joints, the
  usual smoothness measure; ground truth motion capture sets the reference level.

Feet and root (foot skate, contact share, drift, bob, floor penetration, leg jerk) are feet.py's.
"""
from __future__ import annotations

import numpy as np


def jitter(joints: np.ndarray, fps: int = 30, joint_ids: tuple[int, ...] | None = None) -> float:
    p = np.asarray(joints, np.float64)
    if joint_ids is not None:
        p = p[:, list(joint_ids)]
    if len(p) < 4:
        return float("nan")
    jerk = np.diff(p, n=3, axis=0) * fps ** 3
    return float(np.linalg.norm(jerk, axis=-1).mean())
