"""Forward kinematics: equals smplx's joints (mannequin and a synthetic 10,475-vertex SMPL-X-like model),
and its transforms skin the mesh exactly like smplx."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from gesturelsm.body import forward_kinematics, forward_kinematics_aa, load_body_model, skinning_transforms
from gesturelsm.motion.rotations import axis_angle_to_matrix
from gesturelsm.motion.skeleton import PARENTS


def _random_inputs(T: int, seed: int = 0) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    poses = (rng.normal(size=(T, 165)) * 0.4).astype(np.float32)
    trans = rng.normal(size=(T, 3)).astype(np.float32)
    expr = rng.normal(size=(T, 100)).astype(np.float32)
    betas = rng.normal(size=300).astype(np.float32)
    return poses, trans, expr, betas


@pytest.mark.parametrize("flat_hand_mean", [True, False])
def test_fk_matches_smplx_on_a_synthetic_smplx_model(synthetic_smplx_dir, flat_hand_mean):
    body = load_body_model(synthetic_smplx_dir, flat_hand_mean=flat_hand_mean)   # a folder: finds the file
    assert body.num_vertices == 10475
    poses, trans, expr, betas = _random_inputs(6)
    ref = body.forward_smplx(poses, trans, expr, betas)
    np.testing.assert_allclose(body.joints(poses, trans, betas, expr), ref.joints, atol=1e-5)
    # our forward (blend shapes, pose correctives, FK, skinning) equals smplx's mesh too
    ours = body.forward(poses, trans, expr, betas, chunk=4)
    np.testing.assert_allclose(ours.vertices, ref.vertices, atol=2e-5)
    np.testing.assert_allclose(ours.joints, ref.joints, atol=1e-5)
    ref = ref.joints
    # the hand mean matters for this model: with the other setting the fingers land elsewhere
    other = load_body_model(synthetic_smplx_dir, flat_hand_mean=not flat_hand_mean)
    assert np.abs(other.joints(poses, trans, betas, expr)[:, 25:] - ref[:, 25:]).max() > 1e-3


def test_fk_matches_smplx_on_the_mannequin(mannequin):
    poses, trans, expr, betas = _random_inputs(8, seed=1)
    ref = mannequin.forward_smplx(poses, trans, expr, betas)
    np.testing.assert_allclose(mannequin.joints(poses, trans, betas, expr), ref.joints, atol=1e-5)
    ours = mannequin.forward(poses, trans, expr, betas)
    np.testing.assert_allclose(ours.vertices, ref.vertices, atol=2e-5)
    np.testing.assert_allclose(ours.joints, ref.joints, atol=1e-5)


def test_skinning_transforms_reproduce_smplx_vertices(mannequin):
    """The mannequin has no pose correctives, so LBS with our transforms must give smplx's mesh."""
    poses, trans, _, betas = _random_inputs(3, seed=2)
    out = mannequin.forward_smplx(poses, trans, betas=betas)
    m = mannequin.module
    coeffs = mannequin._shape_coeffs(betas)
    dirs = torch.cat([m.shapedirs, m.expr_dirs], -1)
    v_shaped = m.v_template + torch.einsum("bl,vkl->bvk", coeffs, dirs)
    rest = torch.from_numpy(mannequin.rest_joints(betas))
    _, G = forward_kinematics_aa(torch.from_numpy(poses), rest, PARENTS, torch.from_numpy(trans))
    A = skinning_transforms(G, rest)                                          # (T, 55, 4, 4)
    T = torch.einsum("vj,tjab->tvab", m.lbs_weights, A)                       # (T, V, 4, 4)
    v = (T[..., :3, :3] @ v_shaped[0, :, :, None])[..., 0] + T[..., :3, 3]    # (T, V, 3)
    np.testing.assert_allclose(v.numpy(), out.vertices, atol=2e-5)


def test_fk_is_batched_over_leading_dims_and_keeps_bone_lengths():
    rng = torch.Generator().manual_seed(0)
    rest = torch.randn(55, 3, generator=rng)
    R = axis_angle_to_matrix(torch.randn(2, 3, 55, 3, generator=rng))        # (2, 3, 55, 3, 3)
    joints, G = forward_kinematics(R, rest, PARENTS)
    assert joints.shape == (2, 3, 55, 3) and G.shape == (2, 3, 55, 4, 4)
    flat, _ = forward_kinematics(R.reshape(6, 55, 3, 3), rest, PARENTS)
    torch.testing.assert_close(joints.reshape(6, 55, 3), flat)
    par = torch.tensor(PARENTS[1:])
    bone = (joints[..., 1:, :] - joints[..., par, :]).norm(dim=-1)             # rigid motion of each bone
    torch.testing.assert_close(bone, (rest[1:] - rest[par]).norm(dim=-1).expand_as(bone), atol=1e-5, rtol=0)
    ident, _ = forward_kinematics(torch.eye(3).expand(55, 3, 3), rest, PARENTS)
    torch.testing.assert_close(ident, rest)
