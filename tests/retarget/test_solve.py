"""Retargeting the real take onto rigs built here: every mapped bone's world direction follows SMPL-X's
(mean < 2 degrees, p95 < 5), whatever the rest pose, bone lengths, local axes, up axis, units, fingers or spine
segments; the feet stay on the floor when SMPL-X's do; the root moves by the leg-length ratio."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from _rigs import Y_UP_TO_Z_UP, build_rig, direction_errors, posed_world
from gesturelsm.motion.rotations import axis_angle_to_matrix
from gesturelsm.motion.skeleton import JOINT_INDEX
from gesturelsm.retarget import retarget

FRAMES = 450          # 15 s of the take: enough variety, quick


@pytest.fixture(scope="module")
def take(real_motion):
    return real_motion.slice(300, 300 + FRAMES)


RIGS = {
    "tpose": {},
    "apose_bent_elbows": {"apose": 45.0, "elbow": 25.0},
    "other_bone_lengths": {"lengths": 0.3},
    "rotated_bone_axes": {"axes": True},
    "zup_centimetres": {"world": Y_UP_TO_Z_UP, "units": 100.0},
    "no_fingers": {"fingers": False},
    "two_segment_spine": {"spine": 2},
    "all_at_once": {"apose": 40.0, "elbow": 15.0, "lengths": 0.2, "axes": True, "world": Y_UP_TO_Z_UP,
                    "units": 100.0, "fingers": False, "spine": 2},
}


@pytest.mark.parametrize("kind", list(RIGS))
def test_bone_directions_follow_smplx(kind, take, source, smplx_joints):
    skel, to_smplx = build_rig(source.rest_joints, **RIGS[kind])
    result = retarget(take, skel, source)
    err = direction_errors(result, to_smplx, smplx_joints)
    assert err.shape[1] >= (12 if not RIGS[kind].get("fingers", True) else 36)
    assert err.mean() < 2.0 and np.percentile(err, 95) < 5.0, (err.mean(), np.percentile(err, 95))


def test_copying_smplx_rotations_onto_an_a_pose_rig_fails_the_check(take, source, smplx_joints):
    """SMPL-X's local rotations copied onto an A-pose rig leave the arms 45 degrees off: the direction check
    must see that, so the test above can fail."""
    skel, to_smplx = build_rig(source.rest_joints, apose=45.0)
    result = retarget(take, skel, source)
    R = axis_angle_to_matrix(torch.from_numpy(take.poses.reshape(-1, 55, 3).astype(np.float64))).numpy()
    for j, i in skel.bones.items():
        result.local_rotation[:, i] = R[:, JOINT_INDEX[j]]
    err = direction_errors(result, to_smplx, smplx_joints)
    assert err.max(0).max() > 40.0 and err.mean() > 2.0


def test_feet_stay_on_the_floor_when_smplx_feet_do(take, source, smplx_joints):
    skel, to_smplx = build_rig(source.rest_joints, apose=30.0, lengths=0.25, world=Y_UP_TO_Z_UP, units=100.0)
    result = retarget(take, skel, source)
    X = posed_world(result) @ to_smplx.T                          # SMPL-X axes, centimetres
    feet = [skel.bones[f] for f in ("left_ankle", "right_ankle", "left_foot", "right_foot")]
    rest = (skel.world()[:, :3, 3] @ to_smplx.T)[feet, 1].min()
    char_lift = X[:, feet, 1].min(1) - rest
    sx = smplx_joints[:, [JOINT_INDEX[f] for f in ("left_ankle", "right_ankle", "left_foot", "right_foot")], 1]
    smplx_lift = sx.min(1) - sx.min()
    np.testing.assert_allclose(char_lift, result.scale * smplx_lift, atol=1e-3)   # 10 micrometres
    grounded = smplx_lift < 0.01
    assert grounded.mean() > 0.05
    assert char_lift[grounded].max() < 0.01 * result.scale + 1e-3 and char_lift.min() > -1e-3


def test_root_moves_by_leg_length_ratio(take, source, smplx_joints):
    skel, to_smplx = build_rig(source.rest_joints, lengths=0.0, world=Y_UP_TO_Z_UP, units=100.0)
    result = retarget(take, skel, source)
    assert result.scale == pytest.approx(100.0, rel=1e-6)
    X = posed_world(result) @ to_smplx.T
    hips = skel.bones["pelvis"]
    got = X[:, hips, [0, 2]] - X[:1, hips, [0, 2]]
    want = 100.0 * (smplx_joints[:, 0, [0, 2]] - smplx_joints[:1, 0, [0, 2]])
    np.testing.assert_allclose(got, want, atol=1e-3)
