"""Feet and root: does the body stand on the floor, or slide, wander, bob and sink? On world joint positions
(T, 55, 3) from the body model's forward kinematics, SMPL-X joint order, metres, y up, 30 fps.

| measure | definition | unit |
|---|---|---|
| foot skate | mean horizontal speed of the ankles and feet (joints 7, 8, 10, 11) over the frames where that joint is
within `CONTACT_M` (5 cm) of the floor; the floor is the 5th percentile over the take of the lowest of the four joints;
speed between frame t-1 and t, contact judged at t | cm/s |
| contact share | share of (frames x those four joints) within 5 cm of the floor | 0..1 |
| root drift | horizontal distance of the pelvis between the first and the last frame; also per minute of motion | m,
m/min |
| root range | largest horizontal extent of the pelvis path (its diameter: the widest spread along any horizontal
direction) | m |
| bob | standard deviation of the pelvis height | cm |
| floor penetration | 99th percentile over frames of how far the lowest of the four joints is below the floor (0 when
above) | cm |
| leg jerk | mean jerk (third difference of position) of the hips, knees, ankles and feet (1, 2, 4, 5, 7, 8, 10, 11), as
`physics.jitter` | m/s^3 |

The floor is the take's own (a motion shifted up or down measures the same). The speaker's real take
(BEAT2 2_scott_0_1_1 on the shipped mannequin) measures foot skate 6.4 cm/s, contact share 0.59, drift 0.15 m in
64 s, range 1.27 m, bob 2.6 cm, penetration 2.1 cm, leg jerk 31 m/s^3. Measures a motion is too short for are NaN.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..constants import FPS

PELVIS = 0
FOOT_JOINTS: tuple[int, ...] = (7, 8, 10, 11)                 # ankles, feet (toes)
LEG_JOINTS: tuple[int, ...] = (1, 2, 4, 5, 7, 8, 10, 11)      # hips, knees, ankles, feet
CONTACT_M = 0.05
FLOOR_PERCENTILE = 5.0
PENETRATION_PERCENTILE = 99.0
_ANGLES = np.linspace(0.0, np.pi, 180, endpoint=False)                  # every degree of horizontal direction
_DIRECTIONS = np.stack([np.cos(_ANGLES), np.sin(_ANGLES)])               # (2, 180)


@dataclass(frozen=True)
class FeetStats:
    foot_skate: float          # cm/s
    contact_share: float       # 0..1
    root_drift: float          # m, first to last frame, horizontal
    drift_per_min: float       # m per minute of motion
    root_range: float          # m, diameter of the horizontal pelvis path
    bob: float                 # cm, standard deviation of the pelvis height
    penetration: float         # cm, p99 below the floor
    leg_jerk: float            # m/s^3

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


def floor_height(joints: np.ndarray) -> float:
    """The take's floor: the 5th percentile over frames of the lowest foot joint's height (m)."""
    j = np.asarray(joints, np.float64)
    return float(np.percentile(j[:, list(FOOT_JOINTS), 1].min(1), FLOOR_PERCENTILE))


def path_diameter(xz: np.ndarray) -> float:
    """Largest extent of a 2D point set along any direction (within 0.004 % of the exact diameter), m."""
    p = np.asarray(xz, np.float64)
    return float(np.ptp(p @ _DIRECTIONS, axis=0).max()) if len(p) else float("nan")


def foot_skate(joints: np.ndarray, fps: int = FPS, floor: float | None = None) -> tuple[float, float]:
    """(foot skate cm/s, contact share) as defined in the module table; skate is NaN with no contact frame."""
    j = np.asarray(joints, np.float64)[:, list(FOOT_JOINTS)]                   # (T, 4, 3)
    if len(j) < 2:
        return float("nan"), float("nan")
    floor = floor_height(np.asarray(joints)) if floor is None else floor
    near = j[:, :, 1] - floor < CONTACT_M                                       # (T, 4)
    speed = np.linalg.norm(np.diff(j[:, :, [0, 2]], axis=0), axis=-1) * fps     # (T-1, 4)
    c = near[1:]
    skate = float(speed[c].mean() * 100) if c.any() else float("nan")
    return skate, float(near.mean())


def feet_stats(joints: np.ndarray, fps: int = FPS) -> FeetStats:
    """Every measure of the module table for one motion's world joints (T, 55, 3)."""
    j = np.asarray(joints, np.float64)
    if j.ndim != 3 or j.shape[1] < 22 or j.shape[2] != 3:
        raise ValueError(f"expected (T, 55, 3) joint positions, got {j.shape}")
    T = len(j)
    nan = float("nan")
    if T == 0:
        return FeetStats(nan, nan, nan, nan, nan, nan, nan, nan)
    floor = floor_height(j)
    skate, share = foot_skate(j, fps, floor)
    root = j[:, PELVIS]
    drift = float(np.linalg.norm(root[-1, [0, 2]] - root[0, [0, 2]])) if T > 1 else nan
    minutes = T / fps / 60.0
    below = np.maximum(0.0, floor - j[:, list(FOOT_JOINTS), 1].min(1))
    legs = j[:, list(LEG_JOINTS)]
    jerk = float(np.linalg.norm(np.diff(legs, n=3, axis=0), axis=-1).mean() * fps ** 3) if T >= 4 else nan
    return FeetStats(skate, share, drift, drift / minutes if T > 1 else nan, path_diameter(root[:, [0, 2]]),
                     float(root[:, 1].std() * 100), float(np.percentile(below, PENETRATION_PERCENTILE) * 100), jerk)


__all__ = ["CONTACT_M", "FOOT_JOINTS", "FeetStats", "LEG_JOINTS", "feet_stats", "floor_height", "foot_skate",
           "path_diameter"]
