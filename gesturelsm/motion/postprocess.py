"""Post-processing of a finished motion, the same for every method and ground truth (the web app and the
user-study batch both apply it through `pipeline.generate_each`, a single motion through `pipeline.generate`).

- stand in place: the root's horizontal translation (x, z) is set to 0 on every frame; height (y) is kept.
- smoothing: a Savitzky-Golay filter (polynomial order 2) along time on the 6D rotation features of all
  joints (re-orthonormalised when decoded back to axis-angle), window 5 / 9 / 15 frames for
  light / medium / strong (0.17 / 0.3 / 0.5 s at 30 fps); root height and expressions are filtered too.
- fit_length: trim, or hold the last frame, so a motion lasts exactly as long as the speech.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import torch
from scipy.signal import savgol_filter

from ..constants import DEFAULT_SMOOTHING, SMOOTHING_WINDOWS
from ..errors import InputError
from .rotations import axis_angle_to_rot6d, rot6d_to_axis_angle
from .sequence import MotionSequence


def stand_in_place(seq: MotionSequence) -> MotionSequence:
    """Zero the root's horizontal (x, z) translation on every frame; keep its height."""
    trans = seq.trans.copy()
    trans[:, [0, 2]] = 0.0
    return replace(seq, trans=trans)


def check_smoothing(strength: str) -> None:
    if strength not in SMOOTHING_WINDOWS:
        raise InputError(f"Smoothing must be one of {', '.join(SMOOTHING_WINDOWS)} (got {strength!r}).")


def smooth(seq: MotionSequence, strength: str = "medium") -> MotionSequence:
    """Savitzky-Golay (order 2) along time on the 6D rotations, root height and expressions."""
    check_smoothing(strength)
    win = SMOOTHING_WINDOWS[strength]
    T = seq.num_frames
    if win == 0 or T < 4:
        return seq
    win = min(win, T if T % 2 else T - 1)
    poly = min(2, win - 1)
    r6 = axis_angle_to_rot6d(torch.from_numpy(seq.poses.reshape(T, -1, 3))).numpy()      # (T, 55, 6)
    r6 = savgol_filter(r6, win, poly, axis=0)
    poses = rot6d_to_axis_angle(torch.from_numpy(np.ascontiguousarray(r6, np.float32))).numpy().reshape(T, -1)
    trans = seq.trans.copy()
    trans[:, 1] = savgol_filter(trans[:, 1], win, poly)
    expr = savgol_filter(seq.expressions, win, poly, axis=0)
    return replace(seq, poses=poses, trans=trans, expressions=expr)


def fit_length(seq: MotionSequence, num_frames: int) -> MotionSequence:
    """Trim, or hold the last frame, so a motion lasts exactly num_frames."""
    if seq.num_frames >= num_frames:
        return seq.slice(0, num_frames)
    pad = num_frames - seq.num_frames
    rep = lambda a: np.concatenate([a, np.repeat(a[-1:], pad, axis=0)])  # noqa: E731
    return replace(seq, poses=rep(seq.poses), trans=rep(seq.trans), expressions=rep(seq.expressions))


def postprocess(seq: MotionSequence, in_place: bool = False, smoothing: str = "off") -> MotionSequence:
    """Stand in place (if asked), then smooth (if asked)."""
    if in_place:
        seq = stand_in_place(seq)
    return smooth(seq, smoothing) if smoothing != "off" else seq


__all__ = ["DEFAULT_SMOOTHING", "SMOOTHING_WINDOWS", "check_smoothing", "fit_length", "postprocess", "smooth",
           "stand_in_place"]
