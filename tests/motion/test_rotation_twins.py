"""The one rotation module (gesturelsm/motion/rotations.py): each numpy float64 twin gives what its torch
counterpart gives, the quaternion layouts agree, the shortest-arc rotation takes a to b (a half turn for opposite
directions), and the old names elsewhere are these functions."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from gesturelsm.motion import rotations as R


def _aa(n: int, seed: int = 0, near_pi: bool = False) -> np.ndarray:
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    angle = rng.uniform(np.pi - 0.3, np.pi - 1e-3, n) if near_pi else rng.uniform(0, np.pi - 1e-3, n)
    angle[:3] = [0.0, 1e-9, 1e-5]                                   # the series branches too
    return axis * angle[:, None]


@pytest.mark.parametrize("near_pi", [False, True])
def test_matrix_twins_agree_with_torch(near_pi):
    aa = _aa(500, near_pi=near_pi)
    M_t = R.axis_angle_to_matrix(torch.from_numpy(aa)).numpy()
    M_n = R.axis_angle_to_matrix_np(aa)
    assert np.allclose(M_n, M_t, atol=1e-12)
    assert np.allclose(R.matrix_to_axis_angle_np(M_n), R.matrix_to_axis_angle(torch.from_numpy(M_n)).numpy(),
                       atol=1e-9)
    assert np.allclose(R.matrix_to_axis_angle_np(M_n), aa, atol=1e-7)


def test_quaternion_twins_agree_with_torch():
    aa = _aa(500, seed=1)
    wxyz = R.matrix_to_quaternion(R.axis_angle_to_matrix(torch.from_numpy(aa))).numpy()
    xyzw = wxyz[:, [1, 2, 3, 0]]
    M = R.axis_angle_to_matrix_np(aa)
    assert np.allclose(R.matrix_to_quaternion_xyzw(M), xyzw, atol=1e-9)
    assert np.allclose(R.axis_angle_to_quaternion_xyzw(aa), xyzw, atol=1e-9)
    assert np.allclose(R.quaternion_xyzw_to_matrix(xyzw), M, atol=1e-12)
    assert np.allclose(R.quaternion_to_axis_angle(torch.from_numpy(wxyz)).numpy(), aa, atol=1e-7)


def test_the_two_slerps_agree():
    a, b = _aa(200, seed=2), _aa(200, seed=3)
    w = np.random.default_rng(4).uniform(0, 1, 200)
    by_matrix = R.slerp_np(R.axis_angle_to_matrix_np(a), R.axis_angle_to_matrix_np(b), w)
    assert np.allclose(R.axis_angle_to_matrix_np(R.slerp_axis_angle(a, b, w)), by_matrix, atol=1e-9)
    assert np.allclose(R.slerp_np(R.axis_angle_to_matrix_np(a), R.axis_angle_to_matrix_np(b), np.zeros(200)),
                       R.axis_angle_to_matrix_np(a), atol=1e-12)


def test_the_shortest_arc_takes_a_to_b_and_opposite_directions_a_half_turn():
    rng = np.random.default_rng(5)
    a, b = rng.normal(size=(300, 3)), rng.normal(size=(300, 3))
    a[:3] = [[0, 0, 2.0], [1, 0, 0], [0.3, -0.2, 0.9]]
    b[:3] = -a[:3]                                                    # opposite, of any length
    M = R.rotation_between_np(a, b)
    unit = lambda v: v / np.linalg.norm(v, axis=-1, keepdims=True)  # noqa: E731
    assert np.allclose((M @ unit(a)[..., None])[..., 0], unit(b), atol=1e-9)
    assert np.allclose(M @ np.swapaxes(M, -1, -2), np.eye(3), atol=1e-12)
    angles = np.linalg.norm(R.matrix_to_axis_angle_np(M), axis=-1)
    assert np.allclose(angles[:3], np.pi)                             # a half turn, never the identity
    cos = (unit(a) * unit(b)).sum(-1)
    assert np.allclose(angles[3:], np.arccos(np.clip(cos[3:], -1, 1)), atol=1e-7)   # the smallest such rotation


def test_the_old_names_are_the_one_module():
    from gesturelsm.export import glb, player_payload
    from gesturelsm.grounding import rotations as G
    from gesturelsm.motion import merge
    from gesturelsm.retarget import skeleton, vectors

    assert (G.exp, G.log, G.between, G.slerp) == (R.axis_angle_to_matrix_np, R.matrix_to_axis_angle_np,
                                                  R.rotation_between_np, R.slerp_np)
    assert vectors.rotation_between is R.rotation_between_np
    assert skeleton.quat_xyzw_to_matrix is R.quaternion_xyzw_to_matrix
    assert glb.matrix_to_quaternion_xyzw is R.matrix_to_quaternion_xyzw
    assert player_payload.axis_angle_to_quaternion is R.axis_angle_to_quaternion_xyzw
    assert merge.slerp_axis_angle is R.slerp_axis_angle


def test_the_twins_agree_at_exactly_zero_and_exactly_pi():
    rng = np.random.default_rng(6)
    axis = rng.normal(size=(50, 3))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    aa = np.concatenate([np.zeros((1, 3)), axis * np.pi, np.eye(3) * np.pi])       # the identity, half turns
    M_t = R.axis_angle_to_matrix(torch.from_numpy(aa)).numpy()
    M_n = R.axis_angle_to_matrix_np(aa)
    assert np.allclose(M_n, M_t, atol=1e-12)
    assert np.allclose(M_n[0], np.eye(3))
    back_n = R.matrix_to_axis_angle_np(M_n)
    back_t = R.matrix_to_axis_angle(torch.from_numpy(M_n)).numpy()
    assert np.allclose(np.linalg.norm(back_n[1:], axis=-1), np.pi, atol=1e-6)      # a half turn stays one
    assert np.allclose(R.axis_angle_to_matrix_np(back_n), M_n, atol=1e-6)           # (its axis's sign is free)
    assert np.allclose(R.axis_angle_to_matrix_np(back_t), M_n, atol=1e-6)
    xyzw = R.matrix_to_quaternion_xyzw(M_n)
    assert np.allclose(R.quaternion_xyzw_to_matrix(xyzw), M_n, atol=1e-12)
    assert np.allclose(R.quaternion_xyzw_to_matrix(R.axis_angle_to_quaternion_xyzw(aa)), M_n, atol=1e-12)


def test_continuous_quaternions_flip_each_frame_against_the_flipped_previous_one():
    def one_frame_at_a_time(q):
        q = q.copy()
        for t in range(1, len(q)):
            q[t] = np.where((q[t] * q[t - 1]).sum(-1, keepdims=True) < 0, -q[t], q[t])
        return q

    q = np.random.default_rng(7).normal(size=(200, 5, 4)).astype(np.float32)
    q[40, 2], q[41, 2], q[42, 2] = [1, 0, 0, 0], [0, 1, 0, 0], [0, -1, 0, 0]      # a dot product of exactly 0
    got = R.continuous_quaternions(q)
    assert got.dtype == q.dtype and np.array_equal(got, one_frame_at_a_time(q))
    assert ((got[1:] * got[:-1]).sum(-1) >= 0).all()
    from gesturelsm.export import glb

    assert glb.continuous_quaternions is R.continuous_quaternions
