"""Where each foot goes, offline: while in contact the ankle stays where the foot landed, as high as a foot resting
on the floor with the landing's heading (its tilt removed by `level`), and the foot keeps that orientation; for
`blend_frames` after each lift and before each landing the foot eases out of and into the plant (position and
orientation, smoothstep weights, so it leaves and arrives at rest: no pops); otherwise it follows its own motion,
carried by a correction that moves smoothly from one contact's to the next, or that fades out and back in when the
foot stays up longer than `max_gap`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .contacts import segments
from .rotations import slerp, yaw_only


def smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


@dataclass(frozen=True)
class TargetParams:
    blend_frames: int = 8           # frames to ease out of a plant after a lift and into one before a landing
    max_gap: int = 45               # frames: a longer lift lets the correction fade out and back in ...
    fade_frames: int = 10           # ... over this many frames


def correction(orig: np.ndarray, contact: np.ndarray, planted: np.ndarray, p: TargetParams) -> np.ndarray:
    """(T, 3) offset added to the foot's own path `orig` (T, 3): planted - orig in contact (`planted` (T, 3), valid
    in contact frames), interpolated in between (see the module docstring)."""
    T = len(orig)
    off = np.zeros((T, 3))
    runs = segments(contact)
    if not runs:
        return off
    for a, b in runs:
        off[a:b] = planted[a:b] - orig[a:b]
    edges = [(None, runs[0][0])] + [(runs[i][1], runs[i + 1][0]) for i in range(len(runs) - 1)] + [(runs[-1][1], None)]
    for lo, hi in edges:                                             # lo: last contact frame + 1, hi: next contact
        start, stop = (lo or 0), (T if hi is None else hi)
        if stop <= start:
            continue
        t = np.arange(start, stop)
        left = off[lo - 1] if lo is not None else None
        right = off[hi] if hi is not None else None
        if left is not None and right is not None and stop - start <= p.max_gap:
            w = smoothstep((t - (start - 1)) / (stop - start + 1))[:, None]
            off[start:stop] = (1 - w) * left + w * right
            continue
        fade = max(1, p.fade_frames)
        if left is not None:
            off[start:stop] += left * (1 - smoothstep((t - (start - 1)) / (fade + 1)))[:, None]
        if right is not None:
            off[start:stop] += right * smoothstep((t - (stop - fade - 1)) / (fade + 1))[:, None]
    return off


@dataclass
class FootPlan:
    """One foot over a take: (T,) contact, (T,) how strongly the foot is held by its plants (1 in contact, easing
    in and out around each), and per frame the plant it is held by: ankle position (T, 3) and rotation (T, 3, 3)
    (between two plants close in time, a blend of both)."""
    contact: np.ndarray
    weight: np.ndarray
    plant: np.ndarray
    heading: np.ndarray


def plan_foot(ankle: np.ndarray, R_ankle: np.ndarray, contact: np.ndarray, forward: np.ndarray,
              toe_offset: np.ndarray, heights: tuple[float, float], floor: float, level: float,
              p: TargetParams) -> FootPlan:
    """A foot's plan: planted at each landing spot with the landing's heading, its tilt removed by `level` (1:
    flat), its ankle as high as the foot's lowest point (ankle or toe joint, `heights` above the floor when level)
    needs; `ankle` (T, 3) and `R_ankle` (T, 3, 3) the foot's own world position and rotation."""
    T = len(ankle)
    runs = segments(contact)
    if not runs:
        return FootPlan(contact, np.zeros(T), ankle.copy(), R_ankle.copy())
    starts = np.array([a for a, _ in runs])
    stops = np.array([b for _, b in runs])
    heading = slerp(R_ankle[starts], yaw_only(R_ankle[starts], forward), np.full(len(runs), float(level)))
    plant = ankle[starts].copy()
    ankle_h, toe_h = heights
    plant[:, 1] = floor + np.maximum(ankle_h, toe_h - (heading @ toe_offset)[:, 1])
    t = np.arange(T)
    prev = np.searchsorted(starts, t, side="right") - 1                 # the last contact begun by t
    nxt = prev + 1                                                       # the next one
    B = p.blend_frames
    inside = (prev >= 0) & (t < stops[np.maximum(prev, 0)])
    w_prev = np.where(prev >= 0, smoothstep((stops[np.maximum(prev, 0)] + B - t) / (B + 1)), 0.0)
    w_next = np.where(nxt < len(runs), smoothstep((t - (starts[np.minimum(nxt, len(runs) - 1)] - B - 1)) / (B + 1)),
                      0.0)
    w_prev, w_next = np.where(inside, 1.0, w_prev), np.where(inside, 0.0, w_next)
    total = w_prev + w_next
    share = np.where(total > 0, w_next / np.maximum(total, 1e-12), 0.0)            # of the next plant
    i, j = np.maximum(prev, 0), np.minimum(nxt, len(runs) - 1)
    i = np.where(prev >= 0, i, j)
    pos = (1 - share)[:, None] * plant[i] + share[:, None] * plant[j]
    rot = slerp(heading[i], heading[j], share)
    return FootPlan(contact, np.minimum(total, 1.0), pos, rot)


__all__ = ["FootPlan", "TargetParams", "correction", "plan_foot", "smoothstep"]
