"""Where each foot goes, offline: while in contact the ankle stays where the foot landed, as high as a foot resting
on the floor with the landing's heading (its tilt removed by `level`), and the foot keeps that orientation; for
`blend_frames` after each lift and before each landing the foot eases out of and into the plant (position and
orientation, smoothstep weights, so it leaves and arrives at rest: no pops); otherwise it follows its own motion,
carried by a correction that moves smoothly from one contact's to the next, or that fades out and back in when the
foot stays up longer than `max_gap`. A foot travelling from one spot to another is lifted at least by an arc
(sin^2) as high as half the distance (6 cm at most, less for a quick one): it steps, it does not shuffle over the
floor.
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
    clearance: float = 0.5          # a foot travelling between plants is lifted this share of the distance ...
    max_clearance: float = 0.06     # ... up to this high (m) ...
    lift_speed: float = 0.4         # ... and no faster than this at its fastest (m/s)
    travel_speed: float = 0.5       # m/s: a foot leaves its plant early enough to reach the next at this mean speed
    fps: int = 30


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
    """One foot over a take: (T,) contact, (T,) how firmly the foot is held by its plants (1 in contact, easing in
    and out around each), per frame the plant it refers to: ankle position (T, 3) and rotation (T, 3, 3) (between
    two plants close in time, a blend of both), and (T,) the least height its ankle keeps above the plants' while it
    travels between two of them (an arc, as high as `clearance` x the distance, at most `max_clearance`)."""
    contact: np.ndarray
    weight: np.ndarray
    plant: np.ndarray
    heading: np.ndarray
    lift: np.ndarray


def blend(spans: list[tuple[int, int]], T: int, frames: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(weight, i, j, share), each (T,): how firmly each frame is held by the spans (1 inside, smoothstep over
    `frames` outside), by the blend of span i and span j (share of j)."""
    starts = np.array([a for a, _ in spans])
    stops = np.array([b for _, b in spans])
    t = np.arange(T)
    prev = np.searchsorted(starts, t, side="right") - 1                 # the last span begun by t
    nxt = prev + 1                                                       # the next one
    last = len(spans) - 1
    inside = (prev >= 0) & (t < stops[np.maximum(prev, 0)])
    w_prev = np.where(prev >= 0, smoothstep((stops[np.maximum(prev, 0)] + frames - t) / (frames + 1)), 0.0)
    w_next = np.where(nxt <= last, smoothstep((t - (starts[np.minimum(nxt, last)] - frames - 1)) / (frames + 1)), 0.0)
    w_prev, w_next = np.where(inside, 1.0, w_prev), np.where(inside, 0.0, w_next)
    total = w_prev + w_next
    share = np.where(total > 0, w_next / np.maximum(total, 1e-12), 0.0)
    j = np.minimum(nxt, last)
    i = np.where(prev >= 0, prev, j)
    return np.minimum(total, 1.0), i, j, share


def clearance(spans: list[tuple[int, int]], plant: np.ndarray, T: int, p: TargetParams) -> np.ndarray:
    """(T,) the least ankle height above the plants' while a foot travels from one plant to the next (FootPlan)."""
    out = np.zeros(T)
    for k in range(len(spans) - 1):
        a, b = spans[k][1], spans[k + 1][0]
        if 0 < b - a <= p.max_gap:
            travel = np.linalg.norm((plant[k + 1] - plant[k])[[0, 2]])
            u = (np.arange(a, b) - a + 1) / (b - a + 1)
            quick = p.lift_speed * (b - a + 1) / (p.fps * np.pi)       # a short lift cannot go high
            out[a:b] = min(p.clearance * travel, p.max_clearance, quick) * np.sin(np.pi * u) ** 2
    return out


def unhurried(runs: list[tuple[int, int]], plant: np.ndarray, p: TargetParams) -> list[tuple[int, int]]:
    """Contacts that end early enough for the foot to reach its next plant at `travel_speed` on average (a foot
    that has far to go leaves sooner); each keeps at least its first frame."""
    out = list(runs)
    for k in range(len(out) - 1):
        travel = float(np.linalg.norm((plant[k + 1] - plant[k])[[0, 2]]))
        need = int(np.ceil(travel / p.travel_speed * p.fps))
        a, b = out[k]
        if out[k + 1][0] - b < need:
            out[k] = (a, max(a + 1, out[k + 1][0] - need))
    return out


def plan_foot(ankle: np.ndarray, R_ankle: np.ndarray, contact: np.ndarray, forward: np.ndarray,
              toe_offset: np.ndarray, heights: tuple[float, float], floor: float, level: float,
              p: TargetParams) -> FootPlan:
    """A foot's plan: planted at each landing spot with the landing's heading, its tilt removed by `level` (1:
    flat), its ankle as high as the foot's lowest point (ankle or toe joint, `heights` above the floor when level)
    needs; `ankle` (T, 3) and `R_ankle` (T, 3, 3) the foot's own world position and rotation."""
    T = len(ankle)
    runs = segments(contact)
    if not runs:
        return FootPlan(contact, np.zeros(T), ankle.copy(), R_ankle.copy(), np.zeros(T))
    starts = np.array([a for a, _ in runs])
    heading = slerp(R_ankle[starts], yaw_only(R_ankle[starts], forward), np.full(len(runs), float(level)))
    plant = ankle[starts].copy()
    ankle_h, toe_h = heights
    plant[:, 1] = floor + np.maximum(ankle_h, toe_h - (heading @ toe_offset)[:, 1])
    runs = unhurried(runs, plant, p)
    contact = np.zeros(T, bool)
    for a, b in runs:
        contact[a:b] = True
    weight, i, j, share = blend(runs, T, p.blend_frames)
    pos = (1 - share)[:, None] * plant[i] + share[:, None] * plant[j]
    return FootPlan(contact, weight, pos, slerp(heading[i], heading[j], share), clearance(runs, plant, T, p))


__all__ = ["FootPlan", "TargetParams", "blend", "clearance", "correction", "plan_foot", "smoothstep", "unhurried"]
