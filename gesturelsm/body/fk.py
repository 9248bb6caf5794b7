"""Forward kinematics of an SMPL-X-style joint tree, pure torch, batched over any leading dims.

Conventions (SMPL-X's): each joint's rotation acts in its parent's frame about the joint's rest position;
the rest frames are all aligned with the world axes (metres, y up, body facing +z). With rotations R_j and
rest joints J:
    G_0 = [R_0 | J_0],   G_j = G_parent(j) @ [R_j | J_j - J_parent(j)]
Posed joint j = translation of G_j (+ trans). The skinning matrix of joint j is G_j @ [I | -J_j]
(`skinning_transforms`). Matches `smplx.lbs.batch_rigid_transform` and thus smplx's first 55 joints.
"""
from __future__ import annotations

from functools import lru_cache
from typing import Sequence

import torch

from ..motion.rotations import axis_angle_to_matrix


@lru_cache(maxsize=16)
def _levels(parents: tuple[int, ...]) -> tuple[tuple[int, ...], ...]:
    """Joints grouped by depth in the tree (root level first), so each level is one batched matmul."""
    depth = [0] * len(parents)
    for j in range(1, len(parents)):
        if parents[j] >= j:
            raise ValueError("parents must precede their children")
        depth[j] = depth[parents[j]] + 1
    return tuple(tuple(j for j in range(len(parents)) if depth[j] == d) for d in range(max(depth) + 1))


def forward_kinematics(rotmats: torch.Tensor, rest_joints: torch.Tensor,
                       parents: Sequence[int]) -> tuple[torch.Tensor, torch.Tensor]:
    """Posed joints and global joint transforms.

    rotmats (..., J, 3, 3) local rotations; rest_joints (J, 3) or (..., J, 3); parents (J,) with -1 at root.
    Returns joints (..., J, 3) and transforms G (..., J, 4, 4) (rotation and position of each joint frame).
    """
    parents = tuple(int(p) for p in parents)
    lead = rotmats.shape[:-3]
    J = len(parents)
    rest = rest_joints.to(rotmats).expand(*lead, J, 3)                         # (..., J, 3)
    par = torch.tensor([max(p, 0) for p in parents], device=rotmats.device)
    rel = rest - torch.where(torch.tensor(parents, device=rotmats.device)[:, None] >= 0,
                             rest[..., par, :], torch.zeros_like(rest))         # (..., J, 3)
    R_glob = [None] * J
    t_glob = [None] * J
    for level in _levels(parents):
        idx = list(level)
        R_loc = rotmats[..., idx, :, :]                                        # (..., L, 3, 3)
        t_loc = rel[..., idx, :]                                               # (..., L, 3)
        if parents[idx[0]] < 0:
            Rg, tg = R_loc, t_loc
        else:
            pidx = [parents[j] for j in idx]
            Rp = torch.stack([R_glob[p] for p in pidx], -3)                    # (..., L, 3, 3)
            tp = torch.stack([t_glob[p] for p in pidx], -2)                    # (..., L, 3)
            Rg = Rp @ R_loc
            tg = tp + (Rp @ t_loc[..., None])[..., 0]
        for k, j in enumerate(idx):
            R_glob[j], t_glob[j] = Rg[..., k, :, :], tg[..., k, :]
    R = torch.stack(R_glob, -3)                                                # (..., J, 3, 3)
    t = torch.stack(t_glob, -2)                                                # (..., J, 3)
    G = torch.zeros(*lead, J, 4, 4, dtype=rotmats.dtype, device=rotmats.device)
    G[..., :3, :3] = R
    G[..., :3, 3] = t
    G[..., 3, 3] = 1.0
    return t, G


def skinning_transforms(G: torch.Tensor, rest_joints: torch.Tensor) -> torch.Tensor:
    """(..., J, 4, 4) transforms taking rest-pose points to posed points for each joint: G @ [I | -J]."""
    A = G.clone()
    A[..., :3, 3] = G[..., :3, 3] - (G[..., :3, :3] @ rest_joints.to(G)[..., None])[..., 0]
    return A


def forward_kinematics_aa(poses: torch.Tensor, rest_joints: torch.Tensor, parents: Sequence[int],
                          trans: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """Axis-angle convenience: poses (..., J*3) or (..., J, 3); trans (..., 3) added to joints and G."""
    J = len(parents)
    aa = poses.reshape(*poses.shape[:-1], J, 3) if poses.shape[-1] == J * 3 else poses  # (..., J, 3)
    joints, G = forward_kinematics(axis_angle_to_matrix(aa), rest_joints, parents)
    if trans is not None:
        joints = joints + trans[..., None, :]
        G = G.clone()
        G[..., :3, 3] = G[..., :3, 3] + trans[..., None, :]
    return joints, G
