"""Fixtures for render tests: the mannequin, short deterministic motions, speech-like audio."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.motion import JOINT_NAMES, MotionSequence

L_SHOULDER, R_SHOULDER = JOINT_NAMES.index("left_shoulder"), JOINT_NAMES.index("right_shoulder")
STAND_Y = 1.3026  # mannequin soles at y = 0 (assets/body/MANNEQUIN.md)


def pose_motion(frames: int, arm_angle: float | np.ndarray, x: float = 0.0) -> MotionSequence:
    """Standing, arms rotated about z by `arm_angle` rad (0 = T-pose, -1.2 = down, +1.2 = raised),
    per frame when an array."""
    a = np.broadcast_to(np.asarray(arm_angle, np.float64), (frames,))
    poses = np.zeros((frames, 165))
    poses[:, 3 * L_SHOULDER + 2] = a          # left arm lies along +x: +z rotation raises it
    poses[:, 3 * R_SHOULDER + 2] = -a         # right arm along -x: mirrored
    trans = np.tile([x, STAND_Y, 0.0], (frames, 1))
    return MotionSequence(poses, trans, np.zeros((frames, 100)))


@pytest.fixture
def make_pose():
    """make_pose(frames, arm_angle, x=0.0) -> MotionSequence (see pose_motion)."""
    return pose_motion


@pytest.fixture
def arms_down():
    return pose_motion(4, -1.2)


@pytest.fixture
def arms_up():
    return pose_motion(4, 1.2)
