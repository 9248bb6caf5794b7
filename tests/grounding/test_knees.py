"""Standing straight: the default grounding keeps the knees as straight as the motion had them (median
knee flexion within 3 degrees of the ungrounded motion's), its feet planted and on the floor, without a knee snap at
landings and lifts (tests/grounding/test_grounding.py `test_contact_transitions_are_continuous`); the rule before it
(`GroundingSettings(straight=False)`: the root as low as the lowest-reaching planted leg asks) bends them about
twice as much on the real take (docs/GROUNDING.md)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from gesturelsm.evaluation.motion_stats import stats_body
from gesturelsm.grounding import GroundingSettings, ground_motion
from gesturelsm.grounding.motion import knee_flexion
from gesturelsm.metrics.feet import feet_stats
from gesturelsm.motion import MotionSequence

from .test_grounding import assert_pinned, joints, sliding_left_foot, standing
from _support import BEAT2

TAKE = BEAT2 / "smplxflame_30" / "2_scott_0_1_1.npz"
LOWEST = GroundingSettings(straight=False)


def test_knee_flexion_measures_the_angle_between_thigh_and_shin():
    seq = standing(1.0)                                               # knees bent by 0.15 rad (8.6 degrees)
    assert knee_flexion(joints(seq)) == pytest.approx(np.degrees(0.15), abs=0.5)
    straight = replace(seq, poses=np.zeros_like(seq.poses))
    assert knee_flexion(joints(straight)) < 1.0


def test_one_foot_higher_than_the_other_does_not_bend_the_knees():
    """The right foot stands 2 cm higher than the left (a take's noise): putting both on the floor bends the left
    knee by the old rule (the test can fail); the default keeps the knees within 3 degrees and plants both feet."""
    seq = sliding_left_foot(standing(seconds=8.0, seed=1), swing=0.03)
    poses = seq.poses.copy()
    poses[:, 3 * 5] = 0.05                                            # the right knee almost straight ...
    poses[:, 3 * 2] = -0.025                                          # ... its foot level, so 2 cm higher
    poses[:, 3 * 8] = -0.025
    seq = replace(seq, poses=poses)
    before = knee_flexion(joints(seq))
    res = ground_motion(seq)
    assert res.note is None and res.contacts.mean() > 0.8
    assert abs(knee_flexion(joints(res.motion)) - before) <= 3.0
    bent = ground_motion(seq, settings=LOWEST)
    assert knee_flexion(joints(bent.motion)) - before > 3.0
    assert_pinned(res.motion, res.contacts, tol=0.02)                 # a heel lifted on its toe joint: 2 cm at most
    J = joints(res.motion)
    rig_floor = feet_stats(J)
    assert rig_floor.penetration == 0.0


def test_the_real_take_keeps_its_knees():
    if not TAKE.exists():
        pytest.skip(f"{TAKE} is absent (the real BEAT2 take lives in ../shared)")
    seq = MotionSequence.load(TAKE)
    body = stats_body()
    before = knee_flexion(body.joints(seq.poses, seq.trans))
    res = ground_motion(seq)
    after = body.joints(res.motion.poses, res.motion.trans)
    assert res.note is None
    assert abs(knee_flexion(after) - before) <= 3.0 and knee_flexion(after) <= 14.0
    s0, s1 = feet_stats(body.joints(seq.poses, seq.trans)), feet_stats(after)
    assert s1.foot_skate <= s0.foot_skate and s1.penetration <= 1.0
