"""Analytic two-bone IK of one leg per frame, batched over any leading dims: the knee turns about its own hinge
axis (the thigh's `knee_axis`, not the thigh-shin plane, which is undefined for a straight leg) by the angle that
makes the hip-to-ankle distance the target's, always to the side a knee bends; then the hip swings the whole leg,
by the smallest rotation, until the ankle is on the target. The knee's change is a pure flexion about its own
axis, and the bones keep their lengths (only rotations change).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .rotations import about, between, normalize

REACH = 0.997          # the furthest a leg is stretched (unless it already was): this share of thigh + shin


@dataclass
class LegPose:
    """World rotations of the hip and knee joints (..., 3, 3) and the knee and ankle positions (..., 3)."""
    R_hip: np.ndarray
    R_knee: np.ndarray
    knee: np.ndarray
    ankle: np.ndarray


def flexion(thigh: np.ndarray, shin: np.ndarray, axis: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """(...) the angle to turn `shin` about the unit `axis` (both (..., 3), at the knee) so that |thigh + shin| is
    `dist`: with shin(phi) = shin_par + cos(phi) shin_perp + sin(phi) axis x shin, |thigh + shin(phi)|^2 = const +
    2 (A cos(phi) + B sin(phi)), solved on the branch that bends the knee further than straight."""
    par = (shin * axis).sum(-1, keepdims=True) * axis
    perp = shin - par
    A = (thigh * perp).sum(-1)
    B = (thigh * np.cross(axis, shin)).sum(-1)
    C = (dist ** 2 - (thigh ** 2).sum(-1) - (shin ** 2).sum(-1)) / 2 - (thigh * par).sum(-1)
    R = np.maximum(np.hypot(A, B), 1e-12)
    phi = np.arctan2(B, A) + np.arccos(np.clip(C / R, -1.0, 1.0))
    return (phi + np.pi) % (2 * np.pi) - np.pi


def two_bone(hip: np.ndarray, knee: np.ndarray, ankle: np.ndarray, R_hip: np.ndarray, R_knee: np.ndarray,
             target: np.ndarray, knee_axis: np.ndarray, reach: float = REACH,
             longest: np.ndarray | None = None) -> LegPose:
    """The leg (hip, knee, ankle world positions and the hip's and knee's world rotations, from forward kinematics)
    with its ankle moved to `target` (..., 3); `knee_axis` (3,) the axis the knee bends about in the thigh's rest
    frame (+x for SMPL-X: a positive turn swings the shin back). A target out of reach is approached along the same
    line as far as the leg reaches: `reach` of its length, or as far as it was already stretched (or `longest` (...),
    when given, instead of the latter)."""
    thigh, shin = knee - hip, ankle - knee
    L1 = np.linalg.norm(thigh, axis=-1)
    L2 = np.linalg.norm(shin, axis=-1)
    axis = normalize(R_hip @ np.asarray(knee_axis, np.float64))
    d = target - hip
    stretched = np.linalg.norm(ankle - hip, axis=-1) if longest is None else longest
    longest = np.maximum(reach * (L1 + L2), np.minimum(stretched, L1 + L2 - 1e-6))
    dist = np.clip(np.linalg.norm(d, axis=-1), np.abs(L1 - L2) + 1e-4, longest)
    bend = about(axis, flexion(thigh, shin, axis, dist))
    ankle1 = knee + (bend @ shin[..., None])[..., 0]
    swing = between(ankle1 - hip, d)
    knee_new = hip + (swing @ thigh[..., None])[..., 0]
    ankle_new = hip + (swing @ (ankle1 - hip)[..., None])[..., 0]
    return LegPose(swing @ R_hip, swing @ bend @ R_knee, knee_new, ankle_new)


__all__ = ["LegPose", "REACH", "flexion", "two_bone"]
