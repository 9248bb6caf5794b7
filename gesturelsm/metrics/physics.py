"""Physical plausibility: jitter and foot skating, on joint positions (T, 55, 3) in metres, 30 fps, y up.

- `jitter`: mean magnitude of the third derivative of position (jerk, m/s^3) over frames and joints, the
  usual smoothness measure; ground truth motion capture sets the reference level.
- `foot_skating`: while a foot is in contact with the ground, it should not slide. A foot joint (ankles 7, 8
  and feet 10, 11) is in contact in a frame when its height is within `contact_m` (2.5 cm) of its lowest
  height in the sequence and its vertical speed is small; skating is the mean horizontal speed (m/s) of the
  foot joints in contact frames (0 for perfectly planted feet), and `ratio` the share of contact frames
  sliding faster than `slide_ms` (0.1 m/s).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FOOT_JOINTS: tuple[int, ...] = (7, 8, 10, 11)


def jitter(joints: np.ndarray, fps: int = 30, joint_ids: tuple[int, ...] | None = None) -> float:
    p = np.asarray(joints, np.float64)
    if joint_ids is not None:
        p = p[:, list(joint_ids)]
    if len(p) < 4:
        return float("nan")
    jerk = np.diff(p, n=3, axis=0) * fps ** 3
    return float(np.linalg.norm(jerk, axis=-1).mean())


@dataclass(frozen=True)
class FootSkating:
    speed: float            # m/s, mean horizontal foot speed while in contact
    ratio: float            # share of contact frames sliding faster than slide_ms
    contact: float          # share of frames x foot joints in contact


def foot_skating(joints: np.ndarray, fps: int = 30, contact_m: float = 0.025, vertical_ms: float = 0.1,
                 slide_ms: float = 0.1, joint_ids: tuple[int, ...] = FOOT_JOINTS) -> FootSkating:
    p = np.asarray(joints, np.float64)[:, list(joint_ids)]                      # (T, F, 3)
    v = np.diff(p, axis=0) * fps                                                # (T-1, F, 3)
    h = p[1:, :, 1]
    contact = (h - p[:, :, 1].min(0) < contact_m) & (np.abs(v[..., 1]) < vertical_ms)
    horiz = np.linalg.norm(v[..., [0, 2]], axis=-1)
    if not contact.any():
        return FootSkating(0.0, 0.0, 0.0)
    s = horiz[contact]
    return FootSkating(float(s.mean()), float((s > slide_ms).mean()), float(contact.mean()))
