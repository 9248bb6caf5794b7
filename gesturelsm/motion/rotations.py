"""Rotation conversions, batched over any leading dims: the package's one rotation module. In torch (the model side)
and, with the suffix `_np` or a quaternion layout in the name, their numpy float64 twins (grounding, retargeting,
exporters); tests/motion/test_rotation_twins.py holds each twin to its torch counterpart.

Conventions:
- axis-angle: (..., 3) vector, direction = axis, norm = angle in radians (SMPL-X `poses`).
- matrix: (..., 3, 3), acts on column vectors (x' = R x).
- 6D: the first two **rows** of R, flattened: (R00, R01, R02, R10, R11, R12) (pytorch3d / BEAT2 convention).
  Decoding normalises row 0, Gram-Schmidt-orthogonalises row 1 against it, row 2 = row0 x row1.
- quaternion: (w, x, y, z) in torch; (x, y, z, w) in the `_xyzw` numpy twins (glTF's and the page player's layout).
"""
from __future__ import annotations

import numpy as np
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


def slerp_axis_angle(a: np.ndarray, b: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(..., 3) axis-angle rotations a, b and weights w broadcastable to (...) -> a exp(w log(a^T b)), in float64
    (`slerp_np` on axis-angle, through the torch conversions)."""
    Ra = axis_angle_to_matrix(torch.from_numpy(np.asarray(a, np.float64)))
    Rb = axis_angle_to_matrix(torch.from_numpy(np.asarray(b, np.float64)))
    delta = matrix_to_axis_angle(Ra.transpose(-1, -2) @ Rb)                     # (..., 3) from a to b
    step = axis_angle_to_matrix(delta * torch.from_numpy(np.asarray(w, np.float64))[..., None])
    return matrix_to_axis_angle(Ra @ step).numpy()


# --- numpy float64 twins --------------------------------------------------------------------------------------------
EPS = 1e-9


def unit_np(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), EPS)


def _skew_np(v: np.ndarray) -> np.ndarray:
    """(..., 3) -> (..., 3, 3) the cross-product matrix [v]x."""
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    o = np.zeros_like(x)
    return np.stack([o, -z, y, z, o, -x, -y, x, o], -1).reshape(v.shape + (3,))


def axis_angle_to_matrix_np(aa: np.ndarray) -> np.ndarray:
    """(..., 3) axis-angle -> (..., 3, 3), Rodrigues with its series near angle 0 (`axis_angle_to_matrix`)."""
    aa = np.asarray(aa, np.float64)
    t2 = (aa * aa).sum(-1)[..., None, None]
    t = np.sqrt(t2)
    small = t2 < 1e-8
    a = np.where(small, 1 - t2 / 6, np.sin(t) / np.where(small, 1.0, t))
    b = np.where(small, 0.5 - t2 / 24, (1 - np.cos(t)) / np.where(small, 1.0, t2))
    K = _skew_np(aa)
    return np.eye(3) + a * K + b * (K @ K)


def matrix_to_axis_angle_np(R: np.ndarray) -> np.ndarray:
    """(..., 3, 3) -> (..., 3) axis-angle, angle in [0, pi] (`matrix_to_axis_angle`: the skew part; near pi its
    quaternion route)."""
    R = np.asarray(R, np.float64)
    v = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    cos2 = R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2] - 1                   # 2 cos(angle)
    sin2 = np.linalg.norm(v, axis=-1)                                       # 2 sin(angle)
    angle = np.arctan2(sin2, cos2)
    scale = np.where(sin2 > 1e-6, angle / np.maximum(sin2, 1e-12), 0.5 + angle * angle / 12)
    aa = v * scale[..., None]
    far = cos2 < -1.8
    if far.any():
        aa[far] = matrix_to_axis_angle(torch.from_numpy(np.ascontiguousarray(R[far]))).numpy()
    return aa


def rotation_between_np(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(..., 3, 3) the shortest rotation taking direction a to direction b (both (..., 3), any length). Opposite
    directions: the half turn about an axis perpendicular to a (any such turn takes a to b)."""
    a, b = unit_np(np.asarray(a, np.float64)), unit_np(np.asarray(b, np.float64))
    axis = np.cross(a, b)
    s = np.linalg.norm(axis, axis=-1, keepdims=True)
    c = np.clip((a * b).sum(-1, keepdims=True), -1.0, 1.0)
    k, angle = axis / np.maximum(s, EPS), np.arctan2(s, c)
    opposite = (s < EPS) & (c < 0)
    if opposite.any():
        a = np.broadcast_to(a, k.shape)
        other = np.where(np.abs(a[..., :1]) < 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
        k = np.where(opposite, unit_np(np.cross(a, other)), k)
        angle = np.where(opposite, np.pi, angle)
    return axis_angle_to_matrix_np(k * angle)


def slerp_np(R0: np.ndarray, R1: np.ndarray, w: np.ndarray) -> np.ndarray:
    """(..., 3, 3) from R0 (w = 0) to R1 (w = 1) along the shortest arc (`slerp_axis_angle` on matrices)."""
    delta = matrix_to_axis_angle_np(np.swapaxes(R0, -1, -2) @ R1)
    return R0 @ axis_angle_to_matrix_np(delta * np.asarray(w)[..., None])


def axis_angle_to_quaternion_xyzw(aa: np.ndarray) -> np.ndarray:
    """(..., 3) axis-angle -> (..., 4) unit quaternions x, y, z, w with w >= 0 (the rotation of
    `matrix_to_quaternion_xyzw(axis_angle_to_matrix_np(aa))`, without building matrices)."""
    aa = np.asarray(aa, np.float64)
    angle = np.linalg.norm(aa, axis=-1, keepdims=True)                                     # (..., 1)
    half = 0.5 * angle
    # sin(a/2)/a -> 1/2 as a -> 0 (Taylor: 1/2 - a^2/48)
    k = np.where(angle > 1e-6, np.sin(half) / np.maximum(angle, 1e-12), 0.5 - angle ** 2 / 48.0)
    q = np.concatenate([aa * k, np.cos(half)], -1)
    return q * np.where(q[..., 3:] < 0, -1.0, 1.0)


def matrix_to_quaternion_xyzw(R: np.ndarray) -> np.ndarray:
    """(..., 3, 3) -> (..., 4) unit quaternions (x, y, z, w), w >= 0 (`matrix_to_quaternion`, reordered)."""
    from scipy.spatial.transform import Rotation

    shape = R.shape[:-2]
    q = Rotation.from_matrix(np.asarray(R, np.float64).reshape(-1, 3, 3)).as_quat()   # x, y, z, w
    q *= np.where(q[:, 3:] < 0, -1.0, 1.0)
    return q.reshape(shape + (4,))


def quaternion_xyzw_to_matrix(q) -> np.ndarray:
    """(..., 4) quaternions (x, y, z, w), normalised first -> (..., 3, 3)."""
    q = np.asarray(q, np.float64)
    q = q / np.maximum(np.linalg.norm(q, axis=-1, keepdims=True), 1e-12)
    x, y, z, w = np.moveaxis(q, -1, 0)
    return np.stack([
        1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
        2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
        2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1).reshape(q.shape[:-1] + (3, 3))


def continuous_quaternions(q: np.ndarray) -> np.ndarray:
    """(T, ..., 4) quaternions, each frame's sign flipped where its dot product with the previous frame (as flipped)
    is negative, so consecutive frames never interpolate the long way round. Vectorised over frames: a frame's sign
    is the running product of the steps' signs, started again at a frame whose dot product is exactly 0 (kept as
    it is)."""
    q = np.asarray(q)
    if len(q) < 2:
        return q.copy()
    d = (q[1:] * q[:-1]).sum(-1)                                                     # (T - 1, ...) before flips
    signs = np.concatenate([np.ones((1,) + d.shape[1:]), np.cumprod(np.where(d < 0, -1.0, 1.0), 0)])
    frame = np.arange(len(q)).reshape((-1,) + (1,) * (d.ndim - 1))
    start = np.maximum.accumulate(np.where(np.concatenate([np.zeros((1,) + d.shape[1:], bool), d == 0]), frame, 0), 0)
    signs = signs * np.take_along_axis(signs, start, 0)
    return q * signs[..., None].astype(q.dtype)
