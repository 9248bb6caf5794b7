"""Rotation conversions, batched over any leading dims, in torch.

Conventions:
- axis-angle: (..., 3) vector, direction = axis, norm = angle in radians (SMPL-X `poses`).
- matrix: (..., 3, 3), acts on column vectors (x' = R x).
- 6D: the first two **rows** of R, flattened: (R00, R01, R02, R10, R11, R12) (pytorch3d / BEAT2 convention).
  Decoding normalises row 0, Gram-Schmidt-orthogonalises row 1 against it, row 2 = row0 x row1.
"""
from __future__ import annotations

import torch
import torch.nn.functional as F


def axis_angle_to_matrix(aa: torch.Tensor) -> torch.Tensor:
    """(..., 3) -> (..., 3, 3) via Rodrigues, with a Taylor expansion near angle 0."""
    theta2 = (aa * aa).sum(-1, keepdim=True)  # (..., 1)
    theta = torch.sqrt(theta2.clamp_min(1e-24))
    small = theta2 < 1e-8
    # sin(t)/t and (1-cos t)/t^2, series for small angles
    a = torch.where(small, 1 - theta2 / 6, torch.sin(theta) / theta)
    b = torch.where(small, 0.5 - theta2 / 24, (1 - torch.cos(theta)) / theta2.clamp_min(1e-24))
    x, y, z = aa.unbind(-1)
    zero = torch.zeros_like(x)
    K = torch.stack([zero, -z, y, z, zero, -x, -y, x, zero], -1).reshape(*aa.shape[:-1], 3, 3)
    eye = torch.eye(3, dtype=aa.dtype, device=aa.device).expand(K.shape)
    return eye + a[..., None] * K + b[..., None] * (K @ K)


def matrix_to_quaternion(R: torch.Tensor) -> torch.Tensor:
    """(..., 3, 3) -> (..., 4) unit quaternion (w, x, y, z) with w >= 0.

    Uses the best-conditioned of the four standard formulas per matrix (no division by a small number).
    """
    m = R
    m00, m01, m02 = m[..., 0, 0], m[..., 0, 1], m[..., 0, 2]
    m10, m11, m12 = m[..., 1, 0], m[..., 1, 1], m[..., 1, 2]
    m20, m21, m22 = m[..., 2, 0], m[..., 2, 1], m[..., 2, 2]
    # 4*q_i^2 for each component, clamped for stability
    q_abs = torch.sqrt(torch.stack([
        1 + m00 + m11 + m22, 1 + m00 - m11 - m22, 1 - m00 + m11 - m22, 1 - m00 - m11 + m22], -1
    ).clamp_min(1e-12))  # (..., 4) = 2|q|
    cands = torch.stack([
        torch.stack([q_abs[..., 0] ** 2, m21 - m12, m02 - m20, m10 - m01], -1),
        torch.stack([m21 - m12, q_abs[..., 1] ** 2, m10 + m01, m02 + m20], -1),
        torch.stack([m02 - m20, m10 + m01, q_abs[..., 2] ** 2, m21 + m12], -1),
        torch.stack([m10 - m01, m20 + m02, m21 + m12, q_abs[..., 3] ** 2], -1),
    ], -2)  # (..., 4, 4); row i = 2|q_i| * q
    cands = cands / (2 * q_abs[..., None])
    best = q_abs.argmax(-1)  # (...,)
    q = torch.gather(cands, -2, best[..., None, None].expand(*best.shape, 1, 4)).squeeze(-2)
    q = F.normalize(q, dim=-1)
    return torch.where(q[..., :1] < 0, -q, q)


def quaternion_to_axis_angle(q: torch.Tensor) -> torch.Tensor:
    """(..., 4) (w, x, y, z) -> (..., 3), angle in [0, pi]."""
    q = torch.where(q[..., :1] < 0, -q, q)
    xyz = q[..., 1:]
    s = xyz.norm(dim=-1, keepdim=True)
    angle = 2 * torch.atan2(s, q[..., :1])  # in [0, pi]
    # angle / sin(angle/2), series near 0
    small = s < 1e-6
    scale = torch.where(small, 2 / q[..., :1].clamp_min(1e-12), angle / s.clamp_min(1e-12))
    return xyz * scale


def matrix_to_axis_angle(R: torch.Tensor) -> torch.Tensor:
    """(..., 3, 3) -> (..., 3), angle in [0, pi].

    Directly from the skew part: v = (R21 - R12, R02 - R20, R10 - R01) = 2 sin(angle) * axis and
    2 cos(angle) = trace - 1, so aa = v * angle / |v| (series angle / (2 sin angle) ~ 1/2 + angle^2 / 12 near 0).
    About 3x faster than going through quaternions. Near pi the skew part vanishes and loses precision, so
    angles above ~2.69 rad (cos < -0.9, rare in body poses) take the quaternion route."""
    v = torch.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    cos2 = R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2] - 1                     # 2 cos(angle)
    sin2 = v.norm(dim=-1)                                                     # 2 sin(angle)
    angle = torch.atan2(sin2, cos2)
    scale = torch.where(sin2 > 1e-6, angle / sin2.clamp_min(1e-12), 0.5 + angle * angle / 12)
    aa = v * scale[..., None]
    far = cos2 < -1.8
    if bool(far.any()):
        aa[far] = quaternion_to_axis_angle(matrix_to_quaternion(R[far]))
    return aa


def matrix_to_rot6d(R: torch.Tensor) -> torch.Tensor:
    """(..., 3, 3) -> (..., 6): first two rows."""
    return R[..., :2, :].reshape(*R.shape[:-2], 6)


def rot6d_to_matrix(d6: torch.Tensor) -> torch.Tensor:
    """(..., 6) -> (..., 3, 3) by Gram-Schmidt on the two rows (any non-degenerate input is valid)."""
    a1, a2 = d6[..., :3], d6[..., 3:]
    b1 = F.normalize(a1, dim=-1)
    b2 = F.normalize(a2 - (b1 * a2).sum(-1, keepdim=True) * b1, dim=-1)
    b3 = torch.cross(b1, b2, dim=-1)
    return torch.stack([b1, b2, b3], dim=-2)


def axis_angle_to_rot6d(aa: torch.Tensor) -> torch.Tensor:
    return matrix_to_rot6d(axis_angle_to_matrix(aa))


def rot6d_to_axis_angle(d6: torch.Tensor) -> torch.Tensor:
    return matrix_to_axis_angle(rot6d_to_matrix(d6))


def geodesic_angle(R1: torch.Tensor, R2: torch.Tensor) -> torch.Tensor:
    """Angle in radians of R1^T R2, (..., 3, 3) x2 -> (...)."""
    R = R1.transpose(-1, -2) @ R2
    cos = (R.diagonal(dim1=-2, dim2=-1).sum(-1) - 1) / 2
    sin = torch.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                       R[..., 1, 0] - R[..., 0, 1]], -1).norm(dim=-1) / 2
    return torch.atan2(sin, cos)  # accurate near 0 and pi, unlike acos
