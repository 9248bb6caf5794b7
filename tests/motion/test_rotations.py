import math

import pytest
import torch

from gesturelsm.motion import rotations as R


def random_axis_angle(n: int, max_angle: float = math.pi - 1e-3, seed: int = 0) -> torch.Tensor:
    g = torch.Generator().manual_seed(seed)
    axis = torch.nn.functional.normalize(torch.randn(n, 3, generator=g, dtype=torch.float64), dim=-1)
    angle = torch.rand(n, 1, generator=g, dtype=torch.float64) * max_angle
    return axis * angle


def test_matrix_is_rotation_and_matches_closed_form():
    aa = random_axis_angle(500)
    M = R.axis_angle_to_matrix(aa)
    eye = torch.eye(3, dtype=torch.float64).expand_as(M)
    assert torch.allclose(M.transpose(-1, -2) @ M, eye, atol=1e-12)
    assert torch.allclose(torch.linalg.det(M), torch.ones(500, dtype=torch.float64), atol=1e-12)
    # a rotation of 90 degrees about z maps x to y (column-vector convention)
    Rz = R.axis_angle_to_matrix(torch.tensor([0.0, 0.0, math.pi / 2], dtype=torch.float64))
    assert torch.allclose(Rz @ torch.tensor([1.0, 0, 0], dtype=torch.float64),
                          torch.tensor([0.0, 1, 0], dtype=torch.float64), atol=1e-12)
    # the rotation axis is a fixed point
    assert torch.allclose((M @ aa[..., None])[..., 0], aa, atol=1e-10)


@pytest.mark.parametrize("max_angle", [1e-7, 1e-3, 1.0, math.pi - 1e-3])
def test_axis_angle_round_trip(max_angle):
    aa = random_axis_angle(1000, max_angle)
    back = R.matrix_to_axis_angle(R.axis_angle_to_matrix(aa))
    assert torch.allclose(back, aa, atol=1e-9)
    back32 = R.matrix_to_axis_angle(R.axis_angle_to_matrix(aa.float()))
    assert torch.allclose(back32.double(), aa, atol=2e-5)


def test_axis_angle_both_routes_agree_across_the_switch():
    """Angles just below and above 2.69 rad (where the skew-part route hands over to quaternions)."""
    g = torch.Generator().manual_seed(1)
    axis = torch.nn.functional.normalize(torch.randn(400, 3, generator=g, dtype=torch.float64), dim=-1)
    angle = torch.linspace(2.5, 2.9, 400, dtype=torch.float64)[:, None]
    M = R.axis_angle_to_matrix(axis * angle)
    assert torch.allclose(R.matrix_to_axis_angle(M), axis * angle, atol=1e-12)
    assert torch.allclose(R.matrix_to_axis_angle(M), R.quaternion_to_axis_angle(R.matrix_to_quaternion(M)), atol=1e-12)


def test_6d_round_trip_and_row_layout():
    aa = random_axis_angle(1000)
    M = R.axis_angle_to_matrix(aa)
    d6 = R.matrix_to_rot6d(M)
    assert torch.equal(d6[:, :3], M[:, 0, :]) and torch.equal(d6[:, 3:], M[:, 1, :])  # rows, not columns
    assert torch.allclose(R.rot6d_to_matrix(d6), M, atol=1e-12)
    assert torch.allclose(R.rot6d_to_axis_angle(R.axis_angle_to_rot6d(aa)), aa, atol=1e-9)


def test_6d_decode_orthonormalises_noisy_input():
    M = R.axis_angle_to_matrix(random_axis_angle(200))
    noisy = R.matrix_to_rot6d(M) + 0.01 * torch.randn(200, 6, dtype=torch.float64)
    Q = R.rot6d_to_matrix(noisy)
    assert torch.allclose(Q @ Q.transpose(-1, -2), torch.eye(3, dtype=torch.float64).expand_as(Q), atol=1e-12)
    assert torch.allclose(torch.linalg.det(Q), torch.ones(200, dtype=torch.float64), atol=1e-12)
    assert R.geodesic_angle(Q, M).max() < 0.05


def test_geodesic_angle_equals_rotation_angle():
    aa = random_axis_angle(300)
    eye = torch.eye(3, dtype=torch.float64).expand(300, 3, 3)
    assert torch.allclose(R.geodesic_angle(eye, R.axis_angle_to_matrix(aa)), aa.norm(dim=-1), atol=1e-9)


def test_real_poses_round_trip(real_motion):
    aa = torch.from_numpy(real_motion.poses).double().reshape(-1, 55, 3)
    back = R.rot6d_to_axis_angle(R.axis_angle_to_rot6d(aa))
    # compare as rotations (axis-angle is unique for angles < pi, which BEAT2's are)
    err = R.geodesic_angle(R.axis_angle_to_matrix(aa), R.axis_angle_to_matrix(back))
    assert err.max() < 1e-9
    assert torch.allclose(back, aa, atol=1e-6)
