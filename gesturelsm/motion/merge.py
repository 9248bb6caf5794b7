"""Putting an edit together: the regenerated motion merged into the input, and poses pinned.

`merge_edit` starts from the input's own arrays, so every value a weight of 0 covers (regions not edited, an edited
region outside its ranges) is the input's, bit for bit. An edited region's weight (`edit_weights`) is 1 inside its
ranges except at their ends, where it rises from 0 (and falls back) as a raised cosine: the crossing from the input's
motion to the regenerated one. Each crossing lasts long enough that the turn it adds, pi / 2 * angle / frames at its
steepest, stays within half the input's own 99th-percentile joint speed in that region, where angle is the largest
joint angle between the two motions over the crossing: from RAMP_MIN to RAMP_MAX frames, and at most half the range.
Where a weight w > 0:
- joint rotations move along the geodesic from the input's to the regenerated one, R = R_in exp(w log(R_in^T R_gen))
  (slerp; w = 1 is the regenerated value exactly);
- the root translation (the lower region's) takes the regenerated path shifted, linearly over each edited span, to
  meet the input's at the span's two ends, so the body neither jumps nor ends up somewhere else after the span;
- expressions (the face's) are mixed linearly.
`pin_pose` turns joints so that one frame has a given pose: the rotation that takes the frame's pose to the target
is applied in full at that frame and in part around it (a raised cosine, 0 from `half_width` frames away).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import torch

from ..constants import FPS
from .editing import KEY_SPACING, EditSpec
from .regions import REGIONS
from .rotations import axis_angle_to_matrix, geodesic_angle, matrix_to_axis_angle, slerp_axis_angle
from .sequence import MotionSequence

RAMP_MIN, RAMP_MAX = 6, 30        # frames a crossing at a range's end lasts (0.2-1 s)
RAMP_SPEED_SHARE = 0.5            # of the input's 99th-percentile joint speed the crossing may add at its steepest


def joint_angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(T, J, 3) axis-angle x2 -> (T, J) angle in radians between them."""
    to_m = lambda x: axis_angle_to_matrix(torch.from_numpy(np.asarray(x, np.float64)))  # noqa: E731
    return geodesic_angle(to_m(a), to_m(b)).numpy()


def joint_speeds(poses: np.ndarray) -> np.ndarray:
    """(T, J, 3) axis-angle -> (T - 1, J) angular speed of every joint in rad/s."""
    return joint_angles(poses[:-1], poses[1:]) * FPS


def _ramp_frames(angle: float, budget: float, span: int) -> int:
    """Frames a crossing of `angle` radians takes so that pi / 2 * angle / frames * FPS <= budget (rad/s)."""
    need = int(np.ceil(np.pi / 2 * angle * FPS / max(budget, 1e-6)))
    return int(max(1, min(max(RAMP_MIN, need), RAMP_MAX, span // 2)))


def edit_weights(original: MotionSequence, generated: MotionSequence, spec: EditSpec, region: str) -> np.ndarray:
    """(T,) float64 in [0, 1]: how much of `generated` `region` takes at each frame (module docstring)."""
    inside = spec.frames(region)
    T, j = original.num_frames, list(REGIONS[region].joints)
    a, b = original.poses.reshape(T, -1, 3)[:, j], generated.poses.reshape(T, -1, 3)[:, j]
    angle = joint_angles(a, b).max(1)                                           # (T,) largest joint angle
    budget = RAMP_SPEED_SHARE * float(np.percentile(joint_speeds(a), 99)) if T > 1 else 0.0
    w = np.zeros(T)
    on = np.concatenate([[False], inside, [False]])
    for lo, hi in zip(np.flatnonzero(on[1:] & ~on[:-1]), np.flatnonzero(~on[1:] & on[:-1])):
        n_in = _ramp_frames(float(angle[lo:lo + RAMP_MAX].max()), budget, hi - lo)
        n_out = _ramp_frames(float(angle[max(lo, hi - RAMP_MAX):hi].max()), budget, hi - lo)
        w[lo:hi] = 1.0
        w[lo:lo + n_in] = 0.5 * (1 - np.cos(np.pi * np.arange(1, n_in + 1) / (n_in + 1)))
        w[hi - n_out:hi] = np.minimum(w[hi - n_out:hi],
                                      0.5 * (1 - np.cos(np.pi * np.arange(n_out, 0, -1) / (n_out + 1))))
    return w


def _blend_joints(out: np.ndarray, gen: np.ndarray, joints: tuple[int, ...], w: np.ndarray) -> None:
    """In place on (T, 55, 3) `out`: the joints move w of the way to `gen` where 0 < w < 1, take `gen` where w == 1."""
    j = np.asarray(joints, np.intp)
    full, part = w >= 1.0, (w > 0) & (w < 1.0)
    out[np.ix_(full, j)] = gen[np.ix_(full, j)]
    if part.any():
        out[np.ix_(part, j)] = slerp_axis_angle(out[np.ix_(part, j)], gen[np.ix_(part, j)], w[part][:, None])


def _blend_trans(trans: np.ndarray, gen: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The input's translation `trans` (T, 3) with each span of w > 0 taking the regenerated path `gen`, offset to
    meet the input at the span's ends (linearly in between), mixed by w."""
    out = trans.astype(np.float64)
    on = np.concatenate([[False], w > 0, [False]])
    starts, stops = np.flatnonzero(on[1:] & ~on[:-1]), np.flatnonzero(~on[1:] & on[:-1])
    for a, b in zip(starts, stops):
        u = np.linspace(0.0, 1.0, b - a)[:, None] if b - a > 1 else np.zeros((1, 1))
        offset = (trans[a] - gen[a]) * (1 - u) + (trans[b - 1] - gen[b - 1]) * u
        shifted = gen[a:b] + offset
        ww = w[a:b, None]
        out[a:b] = np.where(ww >= 1.0, shifted, trans[a:b] * (1 - ww) + shifted * ww)
    return out


def merge_edit(original: MotionSequence, generated: MotionSequence, spec: EditSpec) -> MotionSequence:
    """`original` with each region of `spec` taken from `generated` (same length) by the spec's weights."""
    if generated.num_frames != original.num_frames:
        raise ValueError(f"generated motion has {generated.num_frames} frames, the input {original.num_frames}")
    T = original.num_frames
    poses = original.poses.reshape(T, -1, 3).copy()
    gen_poses = generated.poses.reshape(T, -1, 3)
    trans, expressions = original.trans.copy(), original.expressions.copy()
    for name in spec.regions:
        region, w = REGIONS[name], edit_weights(original, generated, spec, name)
        _blend_joints(poses, gen_poses, region.joints, w)
        on = w > 0
        if region.trans:
            trans[on] = _blend_trans(original.trans, generated.trans, w)[on]
        if region.expressions:
            expressions[on] = (original.expressions[on] * (1 - w[on, None])
                               + generated.expressions[on] * w[on, None])
    return replace(original, poses=poses.reshape(T, -1), trans=trans, expressions=expressions)


def splice(original: MotionSequence, part: MotionSequence, start: int, regions: tuple[str, ...]) -> MotionSequence:
    """`original` with `regions` taken from `part` over frames [start, start + len(part)): their joints, and the
    translation (shifted to start where the original is at `start`) or expressions when a region owns them."""
    T, n = original.num_frames, part.num_frames
    poses = original.poses.reshape(T, -1, 3).copy()
    trans, expressions = original.trans.copy(), original.expressions.copy()
    for name in regions:
        region = REGIONS[name]
        poses[start:start + n, list(region.joints)] = part.poses.reshape(n, -1, 3)[:, list(region.joints)]
        if region.trans:
            shift = original.trans[start] - part.trans[0]
            trans[start:start + n] = part.trans + np.array([shift[0], 0.0, shift[2]], np.float32)
        if region.expressions:
            expressions[start:start + n] = part.expressions
    return replace(original, poses=poses.reshape(T, -1), trans=trans, expressions=expressions)


def pin_pose(motion: MotionSequence, frame: int, pose: np.ndarray, joints: tuple[int, ...],
             half_width: int) -> MotionSequence:
    """`motion` with `joints` turned so that they have `pose`'s rotations at `frame` exactly: the turn from the
    frame's rotation to the target's is applied in full there, in part over `half_width` frames on each side
    (weight 0.5 (1 + cos(pi d / half_width)) at d frames away), nothing from `half_width` frames away on."""
    T = motion.num_frames
    lo, hi = max(0, frame - half_width + 1), min(T, frame + half_width)
    d = np.abs(np.arange(lo, hi) - frame)
    w = 0.5 * (1 + np.cos(np.pi * d / half_width))
    j = list(joints)
    poses = motion.poses.reshape(T, -1, 3).copy()
    cur = torch.from_numpy(poses[frame, j].astype(np.float64))
    target = torch.from_numpy(np.asarray(pose, np.float64).reshape(-1, 3)[j])
    turn = matrix_to_axis_angle(axis_angle_to_matrix(target) @ axis_angle_to_matrix(cur).transpose(-1, -2))  # (J, 3)
    R = axis_angle_to_matrix(torch.from_numpy(poses[lo:hi, j].astype(np.float64)))
    part = axis_angle_to_matrix(turn[None] * torch.from_numpy(w)[:, None, None])                    # (n, J, 3, 3)
    poses[lo:hi, j] = matrix_to_axis_angle(part @ R).numpy()
    poses[frame, j] = np.asarray(pose, np.float32).reshape(-1, 3)[j]
    return replace(motion, poses=poses.reshape(T, -1))


def apply_edit(original: MotionSequence, generated: MotionSequence, spec: EditSpec) -> MotionSequence:
    """The edited motion: `original` merged with `generated` (`merge_edit`), then each keyframe's pinned regions
    turned onto its pose at its frame (`pin_pose` over KEY_SPACING frames each side)."""
    merged = merge_edit(original, generated, spec)
    for k in spec.keyframes:
        joints = tuple(j for r in spec.pinned(k) for j in REGIONS[r].joints)
        merged = pin_pose(merged, k.frame, k.pose, joints, KEY_SPACING)
    return merged


__all__ = ["RAMP_MAX", "RAMP_MIN", "apply_edit", "edit_weights", "joint_angles", "joint_speeds", "merge_edit",
           "pin_pose", "slerp_axis_angle", "splice"]
