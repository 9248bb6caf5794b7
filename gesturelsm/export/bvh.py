"""BVH export of the SMPL-X skeleton (55 joints, 30 fps) for Blender, MotionBuilder, game engines.

* Units: centimetres by default (`units="cm"`, like BEAT v1's BVH and most mocap BVH; Blender's importer
  takes them with its Scale option, e.g. 0.01), or metres (`units="m"`). Axes as in SMPL-X and most mocap
  BVH: y up, the body faces +z (Blender's importer defaults, Forward -Z / Up Y, convert to its z-up world).
* Hierarchy: SMPL-X's tree, joint names from `skeleton.py` (Hips, Spine, LeftArm, ... or SMPL-X's own);
  offsets are the body model's rest joints for the motion's betas (T-pose), so every joint's rest frame is
  the world frame and its BVH rotation is exactly its SMPL-X local rotation (plus the body model's pose
  mean: SMPL-X's relaxed hands when the body was loaded with flat_hand_mean=False; zero by default).
  Leaves get End Sites (toe and finger tips from the mesh).
* Root: OFFSET 0 0 0 and 6 channels; its positions are the pelvis' world position (trans + rest pelvis), so
  readers that add the offset and readers that take positions as absolute agree.
* Rotations: channels `Zrotation Xrotation Yrotation` for every joint (R = Rz(z) Rx(x) Ry(y), the Mixamo /
  CMU order). With arms along +-x in the rest pose, elbow flexion is a rotation about y, the last axis, so
  ordinary gestures stay far from gimbal lock (middle angle x = +-90 deg); at every frame the Euler triple is
  chosen among its two equivalent solutions and 360-degree wraps to be closest to the previous frame, so
  the curves are continuous for interpolation. Values are written with 6 decimals (degrees):
  re-importing gives the same rotation matrices to ~1e-7 rad.
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import torch

from ..body.model import resolve_body
from ..errors import InputError
from ..motion.rotations import axis_angle_to_matrix
from ..motion.sequence import MotionSequence
from ..motion.skeleton import NUM_JOINTS, PARENTS
from .glb import CHUNK
from .guard import check_motion, finite
from .skeleton import end_sites, full_poses, joint_names

ROT_CHANNELS = ("Zrotation", "Xrotation", "Yrotation")
UNITS = {"cm": 100.0, "m": 1.0}


def matrix_to_euler_zxy(R: np.ndarray) -> np.ndarray:
    """(..., 3, 3) -> (..., 3) radians (z, x, y) with R = Rz(z) @ Rx(x) @ Ry(y); x in [-pi/2, pi/2].

    Near x = +-pi/2 (gimbal lock) z and y are not separable; then y = 0 and z takes the whole turn, which
    still reproduces R."""
    R = np.asarray(R, np.float64)
    # Rz Rx Ry: R[2,1] = sin x, R[0,1] = -sin z cos x, R[1,1] = cos z cos x, R[2,0] = -cos x sin y, R[2,2] = cos x cos y
    sx = np.clip(R[..., 2, 1], -1.0, 1.0)
    cx = np.sqrt(R[..., 0, 1] ** 2 + R[..., 1, 1] ** 2)
    lock = cx < 1e-6
    z = np.where(lock, np.arctan2(R[..., 1, 0], R[..., 0, 0]), np.arctan2(-R[..., 0, 1], R[..., 1, 1]))
    y = np.where(lock, 0.0, np.arctan2(-R[..., 2, 0], R[..., 2, 2]))
    x = np.arctan2(sx, cx)                                   # better conditioned than arcsin near +-pi/2
    return np.stack([z, x, y], -1)


def euler_zxy_to_matrix(e: np.ndarray) -> np.ndarray:
    """(..., 3) radians (z, x, y) -> (..., 3, 3) = Rz(z) @ Rx(x) @ Ry(y)."""
    e = np.asarray(e, np.float64)
    cz, sz = np.cos(e[..., 0]), np.sin(e[..., 0])
    cx, sx = np.cos(e[..., 1]), np.sin(e[..., 1])
    cy, sy = np.cos(e[..., 2]), np.sin(e[..., 2])
    R = np.empty(e.shape[:-1] + (3, 3))
    R[..., 0, 0] = cz * cy - sz * sx * sy
    R[..., 0, 1] = -sz * cx
    R[..., 0, 2] = cz * sy + sz * sx * cy
    R[..., 1, 0] = sz * cy + cz * sx * sy
    R[..., 1, 1] = cz * cx
    R[..., 1, 2] = sz * sy - cz * sx * cy
    R[..., 2, 0] = -cx * sy
    R[..., 2, 1] = sx
    R[..., 2, 2] = cx * cy
    return R


def continuous_euler(e: np.ndarray) -> np.ndarray:
    """(T, J, 3) radians -> the same rotations with each frame's triple closest to the previous frame's:
    between (z, x, y) and (z + pi, pi - x, y + pi), each angle shifted by multiples of 2 pi."""
    e = np.asarray(e, np.float64).copy()
    two_pi = 2 * np.pi
    for t in range(1, len(e)):
        prev = e[t - 1]
        a = e[t]
        b = a + np.array([np.pi, 0.0, np.pi])
        b[:, 1] = np.pi - a[:, 1]
        a = a + two_pi * np.round((prev - a) / two_pi)
        b = b + two_pi * np.round((prev - b) / two_pi)
        use_b = (np.abs(b - prev).sum(-1) < np.abs(a - prev).sum(-1))[:, None]
        e[t] = np.where(use_b, b, a)
    return e


def export_bvh(seq: MotionSequence, path: str | Path, body=None, units: str = "cm",
               names: str = "animator") -> Path:
    """Write `seq` as BVH (see the module docstring); returns the path. body: BodyModel / path / None."""
    if units not in UNITS:
        raise InputError(f"units={units!r}: use 'cm' or 'm'")
    check_motion(seq)
    label = joint_names(names)
    body = resolve_body(body)
    scale = UNITS[units]
    path = Path(path)
    J = body.rest_joints(seq.betas).astype(np.float64)                       # (55, 3) metres
    ends = end_sites(body, seq.betas)
    T = seq.num_frames

    lines = ["HIERARCHY"]
    order: list[int] = []                                                    # joints in file (DFS) order

    def write(j: int, depth: int) -> None:
        ind = "\t" * depth
        off = np.zeros(3) if j == 0 else (J[j] - J[PARENTS[j]]) * scale
        lines.append(f"{ind}{'ROOT' if j == 0 else 'JOINT'} {label[j]}")
        lines.append(f"{ind}{{")
        lines.append(f"{ind}\tOFFSET {off[0]:.6f} {off[1]:.6f} {off[2]:.6f}")
        chans = (["Xposition", "Yposition", "Zposition"] if j == 0 else []) + list(ROT_CHANNELS)
        lines.append(f"{ind}\tCHANNELS {len(chans)} {' '.join(chans)}")
        order.append(j)
        kids = [c for c in range(NUM_JOINTS) if PARENTS[c] == j]
        for c in kids:
            write(c, depth + 1)
        if not kids:
            e = ends[j] * scale
            lines.extend([f"{ind}\tEnd Site", f"{ind}\t{{", f"{ind}\t\tOFFSET {e[0]:.6f} {e[1]:.6f} {e[2]:.6f}",
                          f"{ind}\t}}"])
        lines.append(f"{ind}}}")

    write(0, 0)
    lines += ["MOTION", f"Frames: {T}", f"Frame Time: {1.0 / seq.fps:.7f}"]
    chunks, prev = [], None
    for a in range(0, T, CHUNK):               # in chunks of frames, each continuous with the one before
        part = seq.slice(a, a + CHUNK)
        R = axis_angle_to_matrix(torch.from_numpy(full_poses(part, body).reshape(-1, NUM_JOINTS, 3))).numpy()
        e = matrix_to_euler_zxy(R)
        e = continuous_euler(e if prev is None else np.concatenate([prev, e]))[0 if prev is None else 1:]
        prev = e[-1:]
        root_pos = (part.trans.astype(np.float64) + J[0]) * scale          # (t, 3)
        data = np.concatenate([root_pos, np.degrees(e)[:, order].reshape(len(e), -1)], 1)   # (t, 3 + 165)
        finite(data, "the BVH channels")
        buf = io.StringIO()
        np.savetxt(buf, data, fmt="%.6f", delimiter=" ")
        chunks.append(buf.getvalue())
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n" + "".join(chunks))
    return path
