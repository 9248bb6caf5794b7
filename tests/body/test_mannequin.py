"""The built-in mannequin: SMPL-X compatibility, skinning invariants, designed joints, face and blend shapes."""
from __future__ import annotations


import numpy as np
import pytest
import torch
import trimesh

from gesturelsm.body.mannequin import DEFAULT_PATH, build_mannequin
from gesturelsm.body.mannequin_skeleton import MEAN_TRANS_Y, build_rest_skeleton
from gesturelsm.motion.skeleton import JOINT_INDEX as JI
from gesturelsm.motion.skeleton import JOINT_NAMES, PARENTS


def test_shipped_file_equals_rebuild(mannequin_arrays):
    built = build_mannequin()
    assert sorted(built) == sorted(mannequin_arrays), "keys differ: run `gesturelsm body build`"
    for k, v in built.items():
        s = mannequin_arrays[k]
        assert v.shape == s.shape and v.dtype == s.dtype, k
        if v.dtype.kind == "f":
            np.testing.assert_allclose(v, s, atol=1e-6, err_msg=f"{k} drifted: run `gesturelsm body build`")
        else:
            np.testing.assert_array_equal(v, s, err_msg=k)


def test_asset_is_small_and_light():
    a = dict(np.load(DEFAULT_PATH))
    assert DEFAULT_PATH.stat().st_size < 3e6
    assert 3000 <= len(a["v_template"]) <= 8000


def test_loads_through_smplx_create_with_its_own_vertex_ids(tmp_path, mannequin_arrays):
    import smplx
    from smplx.vertex_joint_selector import VertexJointSelector

    assert DEFAULT_PATH.name.startswith("SMPLX_")  # smplx.create picks the class from this name prefix
    model = smplx.create(str(DEFAULT_PATH), model_type="smplx", ext="npz", use_pca=False, num_betas=300,
                         num_expression_coeffs=100, flat_hand_mean=True)
    assert model.v_template.shape[0] == len(mannequin_arrays["v_template"])
    with pytest.raises((IndexError, RuntimeError)):  # smplx's hard-coded SMPL-X vertex ids (up to 9929) do not fit
        model()
    ids = dict(zip(mannequin_arrays["vertex_id_names"].tolist(), mannequin_arrays["vertex_id_values"].tolist()))
    model.vertex_joint_selector = VertexJointSelector(vertex_ids=ids)
    rng = np.random.default_rng(0)
    pose = torch.from_numpy(rng.normal(scale=0.3, size=(1, 165)).astype(np.float32))
    out = model(global_orient=pose[:, :3], body_pose=pose[:, 3:66], jaw_pose=pose[:, 66:69],
                leye_pose=pose[:, 69:72], reye_pose=pose[:, 72:75], left_hand_pose=pose[:, 75:120],
                right_hand_pose=pose[:, 120:165])
    assert out.joints.shape[1] == 55 + 21 + 51  # joints + extra vertex joints + landmarks
    # the project's loader gives the same body as plain smplx.create
    from gesturelsm.body import load_body_model

    ours = load_body_model().forward(pose.numpy(), np.zeros((1, 3), np.float32))
    np.testing.assert_allclose(ours.vertices[0], out.vertices[0].detach().numpy(), atol=1e-4)


def test_skinning_weights_are_a_partition_of_unity(mannequin_arrays):
    W = mannequin_arrays["weights"].astype(np.float64)
    assert W.min() >= 0
    np.testing.assert_allclose(W.sum(1), 1.0, atol=1e-6)
    # every joint moves some vertices (eyes, jaw and all 30 finger joints included)
    assert (W.max(0) > 0.5).all(), [JOINT_NAMES[j] for j in np.nonzero(W.max(0) <= 0.5)[0]]


def test_regressor_reproduces_the_designed_joints(mannequin_arrays):
    J = mannequin_arrays["J_regressor"].astype(np.float64) @ mannequin_arrays["v_template"].astype(np.float64)
    designed = build_rest_skeleton().joints
    np.testing.assert_allclose(J, designed, atol=2e-6)
    np.testing.assert_array_equal(mannequin_arrays["kintree_table"][0, 1:], PARENTS[1:])
    np.testing.assert_allclose(mannequin_arrays["J_regressor"].sum(1), 1.0, atol=1e-5)


def test_rest_pose_layout_matches_smplx_conventions():
    J = build_rest_skeleton().joints
    assert J[JI["left_wrist"], 0] > 0.6 and J[JI["right_wrist"], 0] < -0.6        # T-pose, left is +x
    assert abs(J[JI["left_wrist"], 1] - J[JI["left_shoulder"], 1]) < 1e-9         # arms horizontal
    assert J[JI["head"], 1] > J[JI["neck"], 1] > J[JI["spine3"], 1] > J[JI["pelvis"], 1] > J[JI["left_knee"], 1]
    assert J[JI["left_foot"], 2] > J[JI["left_ankle"], 2] + 0.05                    # feet point to +z
    assert J[JI["left_thumb1"], 2] > J[JI["left_index1"], 2] - 0.02                 # thumb on the front side
    assert J[JI["left_thumb3"], 2] > J[JI["left_index1"], 2] + 0.01                 # and pointing forward


def test_soles_on_the_floor_with_mean_beat2_translation(mannequin_arrays):
    v = mannequin_arrays["v_template"]
    assert abs(v[:, 1].min() + MEAN_TRANS_Y) < 0.003
    assert 1.7 < v[:, 1].max() - v[:, 1].min() < 1.9


def test_every_part_is_closed_and_outward(mannequin_arrays):
    v, f, part = mannequin_arrays["v_template"], mannequin_arrays["f"], mannequin_arrays["part_index"]
    for i, name in enumerate(mannequin_arrays["part_names"]):
        ids = np.nonzero(part == i)[0]
        sub = f[np.isin(f, ids).all(1)] - ids[0]
        m = trimesh.Trimesh(v[ids], sub, process=False)
        assert m.is_watertight and m.is_winding_consistent and m.volume > 0, name


def test_vertex_ids_point_at_the_named_features(mannequin_arrays):
    v = mannequin_arrays["v_template"]
    ids = dict(zip(mannequin_arrays["vertex_id_names"].tolist(), mannequin_arrays["vertex_id_values"].tolist()))
    import smplx.vertex_ids

    assert set(ids) == set(smplx.vertex_ids.vertex_ids["smplx"])
    J = build_rest_skeleton().joints
    for side, s in (("left", "l"), ("right", "r")):
        for f in ("thumb", "index", "middle", "ring", "pinky"):  # finger tips: beyond the last joint
            tip, last = v[ids[s + f]], J[JI[f"{side}_{f}3"]]
            assert np.abs(tip[0]) > np.abs(last[0]) + 0.015, s + f
        assert np.sign(v[ids[s + "ear"], 0]) == (1 if side == "left" else -1)
    assert v[ids["LHeel"], 2] < J[JI["left_ankle"], 2] < v[ids["LBigToe"], 2]
    assert v[ids["LBigToe"], 0] < v[ids["LSmallToe"], 0]          # big toe on the inner side of the left foot
    assert v[ids["nose"], 2] > v[ids["leye"], 2] > J[JI["head"], 2]


def test_landmarks_are_valid_face_points(mannequin_arrays):
    bary = mannequin_arrays["lmk_bary_coords"]
    assert bary.shape == (51, 3) and bary.min() >= 0
    np.testing.assert_allclose(bary.sum(1), 1.0, atol=1e-6)
    f, part = mannequin_arrays["f"], mannequin_arrays["part_index"]
    head = list(mannequin_arrays["part_names"]).index("head")
    assert (part[f[mannequin_arrays["lmk_faces_idx"]]] == head).all()


def test_jaw_rotation_opens_the_mouth(mannequin):
    poses = np.zeros((2, 165), np.float32)
    poses[1, 66] = 0.3                                   # jaw: +x rotation opens the mouth
    out = mannequin.forward(poses, np.zeros((2, 3)))
    W = mannequin.module.lbs_weights.numpy()
    dv = out.vertices[1] - out.vertices[0]
    chin = (W[:, JI["jaw"]] > 0.9) & (out.vertices[0, :, 2] > out.joints[0, JI["jaw"], 2] + 0.05)
    assert chin.sum() >= 15 and dv[chin, 1].mean() < -0.015   # chin and lower lip drop by centimetres
    assert (dv[chin, 1] < 0).all()
    eye_y = out.joints[0, JI["left_eye_smplhf"], 1]
    upper = (W[:, JI["head"]] > 0.999) & (out.vertices[0, :, 1] > eye_y)
    assert upper.sum() > 100 and np.abs(dv[upper]).max() < 1e-6


def test_blend_shapes_have_their_meaning(mannequin):
    base = mannequin.height()
    assert mannequin.height(np.array([1.0])) == pytest.approx(base * 1.04, rel=1e-3)    # beta0: height
    v0 = mannequin.forward(np.zeros((1, 165)), np.zeros((1, 3))).vertices[0]
    v1 = mannequin.forward(np.zeros((1, 165)), np.zeros((1, 3)), betas=np.array([1.0])).vertices[0]
    assert abs(v1[:, 1].min() - v0[:, 1].min()) < 1e-5                                # feet stay down
    g = mannequin.forward(np.zeros((1, 165)), np.zeros((1, 3)), betas=np.array([0.0, 1.0])).vertices[0]
    waist = np.abs(v0[:, 1] - (v0[:, 1].min() + 1.05)) < 0.01
    assert np.abs(g[waist, 0]).max() > np.abs(v0[waist, 0]).max() * 1.05               # beta1: girth
    e = np.zeros((1, 100))
    e[0, 0] = 2.0
    m = mannequin.forward(np.zeros((1, 165)), np.zeros((1, 3)), expressions=e).vertices[0]
    assert (m - v0)[:, 1].min() < -0.005 and np.abs(m - v0).max() < 0.02                 # expr0: mouth opens
    with torch.no_grad():
        assert mannequin.rest_joints(expressions=e) == pytest.approx(mannequin.rest_joints(), abs=1e-7)
