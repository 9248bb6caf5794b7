"""Mannequin proportions: the baked constants equal what the BEAT v1 BVH gives; vertical placement."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.body.mannequin_skeleton import ANKLE_HEIGHT, MEAN_TRANS_Y, build_rest_skeleton, leg_drop
from gesturelsm.body.proportions import BVH_PROPORTIONS, bvh_joint_names, derive_proportions
from gesturelsm.motion.skeleton import JOINT_INDEX as JI


def test_constants_equal_the_bvh(bvh_path):
    assert len(bvh_joint_names(bvh_path)) == 75
    derived = derive_proportions(bvh_path)
    assert derived.keys() == BVH_PROPORTIONS.keys()
    for k, v in derived.items():
        np.testing.assert_allclose(v, BVH_PROPORTIONS[k], atol=1e-4, err_msg=k)


def test_mean_translation_constant_equals_the_real_take(take_path):
    with np.load(take_path) as d:
        assert float(d["trans"][:, 1].mean()) == pytest.approx(MEAN_TRANS_Y, abs=5e-5)


def test_skeleton_uses_the_measured_bone_lengths():
    J = build_rest_skeleton().joints
    P = BVH_PROPORTIONS
    L = lambda a, b: float(np.linalg.norm(J[JI[a]] - J[JI[b]]))  # noqa: E731
    assert L("left_shoulder", "left_elbow") == pytest.approx(P["left_shoulder->left_elbow"][0], abs=1e-9)
    assert L("right_elbow", "right_wrist") == pytest.approx(P["left_elbow->left_wrist"][0], abs=1e-9)
    assert L("left_hip", "left_knee") == pytest.approx(-P["left_hip->left_knee"][1], abs=1e-9)
    assert L("left_index1", "left_index2") == pytest.approx(P["index"][1], abs=1e-9)
    assert L("right_middle2", "right_middle3") == pytest.approx(P["middle"][2], abs=1e-9)
    assert L("left_thumb1", "left_thumb2") == pytest.approx(np.linalg.norm(P["left_thumb1->left_thumb2"]), abs=1e-9)
    assert L("left_wrist", "left_ring1") == pytest.approx(P["ring"][0], abs=1e-9)
    # soles at y = 0 for the mean BEAT2 translation
    sk = build_rest_skeleton()
    assert sk.sole_y + MEAN_TRANS_Y == pytest.approx(0.0, abs=1e-9)
    assert J[JI["left_ankle"], 1] - sk.sole_y == pytest.approx(ANKLE_HEIGHT)
    assert J[JI["pelvis"], 1] - sk.sole_y == pytest.approx(leg_drop())
