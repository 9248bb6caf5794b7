"""The shared real character (cryptovoxels.vrm: VRM 0.x, faces -z, 2-segment spine, no thumbs) under the whole
real take: every humanoid bone's world direction follows SMPL-X's within 3 degrees on average."""
from __future__ import annotations


import numpy as np
import pytest
import torch

from _rigs import direction_errors
from gesturelsm.body.fk import forward_kinematics_aa
from gesturelsm.body.model import resolve_body
from gesturelsm.motion.skeleton import PARENTS
from gesturelsm.retarget import load_character, retarget_motion
from _support import VRM



def test_cryptovoxels_follows_the_real_take(real_motion):
    if not VRM.exists():
        pytest.skip(f"the shared character is not at {VRM} (../shared beside the repo)")
    character = load_character(VRM)
    assert character.skeleton.kind == "vrm0" and len(character.skeleton.bones) == 43
    result = retarget_motion(real_motion, character, grounding=False)      # the bones as retargeted
    body = resolve_body(None)
    joints, _ = forward_kinematics_aa(torch.from_numpy(real_motion.poses.astype(np.float64)),
                                      torch.from_numpy(body.rest_joints(real_motion.betas).astype(np.float64)),
                                      PARENTS, torch.from_numpy(real_motion.trans.astype(np.float64)))
    # VRM 0.x faces -z with its left on -x: a half turn about y takes its world to SMPL-X's
    err = direction_errors(result, np.diag([-1.0, 1.0, -1.0]), joints.numpy())
    assert err.shape == (real_motion.num_frames, 32)
    assert err.mean() < 3.0 and np.percentile(err, 95) < 5.0, (err.mean(), np.percentile(err, 95))


def test_cryptovoxels_stands_on_its_own_feet_under_the_real_take(real_motion):
    """Grounded on its own legs (the default), the character's feet slide far less than retargeted (foot skate on its
    own joints, as metrics/feet.py measures SMPL-X's), nothing above its legs turns differently, and its feet stay
    on its floor."""
    if not VRM.exists():
        pytest.skip(f"the shared character is not at {VRM} (../shared beside the repo)")
    from gesturelsm.metrics.feet import feet_stats
    from gesturelsm.retarget.grounding import smplx_joints

    character = load_character(VRM)
    off = retarget_motion(real_motion, character, grounding=False)
    on = retarget_motion(real_motion, character)
    assert on.note is None
    before, after = feet_stats(smplx_joints(off)), feet_stats(smplx_joints(on))
    assert after.foot_skate < 0.75 * before.foot_skate and after.contact_share > 0.5, (before, after)
    assert after.penetration < 1.0
    legs = [character.skeleton.bones[f"{s}_{n}"] for s in ("left", "right") for n in ("hip", "knee", "ankle", "foot")]
    others = [i for i in character.skeleton.bones.values() if i not in legs]
    assert np.array_equal(on.local_rotation[:, others], off.local_rotation[:, others])
