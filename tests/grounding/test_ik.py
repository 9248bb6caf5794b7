"""Two-bone leg IK (grounding/ik.py): it reaches what is reachable exactly, keeps bone lengths, changes the knee by a
pure flexion about its own axis (to the side a knee bends, also from a straight leg), and stops on the line to a
target out of reach."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.grounding.ik import two_bone
from gesturelsm.grounding.rotations import exp, log

X = np.array([1.0, 0.0, 0.0])


def random_legs(n: int, seed: int = 0, straight: bool = False):
    """n legs in world: hip at the origin, thigh 0.42 m and shin 0.40 m along -y in the rest pose, random hip
    rotations and knee flexions about +x (or none)."""
    rng = np.random.default_rng(seed)
    R_hip = exp(rng.normal(0, 0.3, (n, 3)))
    flex = np.zeros(n) if straight else rng.uniform(0.05, 1.2, n)
    R_knee_local = exp(flex[:, None] * X)
    R_knee = R_hip @ R_knee_local
    hip = rng.normal(0, 0.1, (n, 3)) + [0, 0.9, 0]
    knee = hip + R_hip @ np.array([0.0, -0.42, 0.0])
    ankle = knee + R_knee @ np.array([0.0, -0.40, 0.0])
    return hip, knee, ankle, R_hip, R_knee


def test_reachable_targets_are_reached_with_bones_kept_and_a_pure_knee_flexion():
    hip, knee, ankle, R_hip, R_knee = random_legs(500)
    rng = np.random.default_rng(1)
    target = ankle + rng.normal(0, 0.05, ankle.shape)
    dist = np.linalg.norm(target - hip, axis=1)
    ok = (dist < 0.99 * 0.82) & (dist > 0.1)
    sol = two_bone(hip, knee, ankle, R_hip, R_knee, target, X)
    np.testing.assert_allclose(sol.ankle[ok], target[ok], atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(sol.knee - hip, axis=1), 0.42, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(sol.ankle - sol.knee, axis=1), 0.40, atol=1e-9)
    local_new = np.swapaxes(sol.R_hip, -1, -2) @ sol.R_knee
    local_old = np.swapaxes(R_hip, -1, -2) @ R_knee
    change = log(local_new @ np.swapaxes(local_old, -1, -2))                # (n, 3): only about x
    np.testing.assert_allclose(change[:, 1:], 0.0, atol=1e-9)
    flex = log(local_new)
    assert (flex[:, 0] > 0).all()                                           # bent the way a knee bends


def test_a_straight_leg_asked_to_shorten_bends_its_knee_forward():
    hip, knee, ankle, R_hip, R_knee = random_legs(50, seed=2, straight=True)
    target = hip + 0.9 * (ankle - hip)                                      # 10 % closer
    sol = two_bone(hip, knee, ankle, R_hip, R_knee, target, X)
    np.testing.assert_allclose(sol.ankle, target, atol=1e-9)
    local = np.swapaxes(sol.R_hip, -1, -2) @ sol.R_knee
    flex = log(local)
    assert (flex[:, 0] > 0.3).all() and np.allclose(flex[:, 1:], 0.0, atol=1e-9)


def test_a_target_out_of_reach_is_approached_on_its_line():
    hip, knee, ankle, R_hip, R_knee = random_legs(20, seed=3)
    d = ankle - hip
    target = hip + 3.0 * d / np.linalg.norm(d, axis=1, keepdims=True)      # 3 m away
    sol = two_bone(hip, knee, ankle, R_hip, R_knee, target, X, reach=0.99)
    got = sol.ankle - hip
    longest = np.maximum(0.99 * 0.82, np.linalg.norm(d, axis=1))            # a leg already straighter stays so
    np.testing.assert_allclose(np.linalg.norm(got, axis=1), longest, rtol=1e-9)
    np.testing.assert_allclose(got / np.linalg.norm(got, axis=1, keepdims=True),
                               d / np.linalg.norm(d, axis=1, keepdims=True), atol=1e-9)


@pytest.mark.parametrize("angle", [1e-9, 0.3, 2.0, 3.1])
def test_rotation_helpers_round_trip(angle):
    rng = np.random.default_rng(4)
    axis = rng.normal(size=(10, 3))
    aa = axis / np.linalg.norm(axis, axis=1, keepdims=True) * angle
    np.testing.assert_allclose(log(exp(aa)), aa, atol=1e-7)
    R = exp(aa)
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
