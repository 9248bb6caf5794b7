"""Loading body files (path resolution, clear errors for bad files) and posing real BEAT2 frames."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.body import BodyModelError, load_body_model, resolve_model_path
from gesturelsm.body.mannequin import DEFAULT_PATH
from gesturelsm.motion.skeleton import JOINT_INDEX as JI
from gesturelsm.motion.skeleton import JOINT_NAMES


def test_path_resolution_argument_then_env_then_mannequin(monkeypatch, tmp_path, synthetic_smplx_dir):
    monkeypatch.delenv("GESTURELSM_SMPLX_MODEL", raising=False)
    assert resolve_model_path() == DEFAULT_PATH
    monkeypatch.setenv("GESTURELSM_SMPLX_MODEL", str(synthetic_smplx_dir))
    assert resolve_model_path() == synthetic_smplx_dir / "SMPLX_NEUTRAL_2020.npz"
    assert resolve_model_path(DEFAULT_PATH) == DEFAULT_PATH
    monkeypatch.setenv("GESTURELSM_SMPLX_MODEL", str(tmp_path / "gone.npz"))
    with pytest.raises(BodyModelError, match="GESTURELSM_SMPLX_MODEL"):
        resolve_model_path()


def _bad(tmp_path, **drop_or_replace) -> str:
    with np.load(DEFAULT_PATH) as d:
        arrays = {k: d[k] for k in d.files}
    for k, v in drop_or_replace.items():
        if v is None:
            arrays.pop(k)
        else:
            arrays[k] = v
    path = tmp_path / "foo.npz"
    np.savez(path, **arrays)
    return str(path)


@pytest.mark.parametrize("case, pattern", [
    ("missing", r"nothere\.npz: file not found .*SMPLX_NEUTRAL_2020\.npz"),
    ("directory", r"is a directory without SMPLX_NEUTRAL_2020\.npz"),
    ("not_npz", r"notnpz\.npz is not an \.npz file"),
    ("no_regressor", r"foo\.npz is missing 'J_regressor' — expected an SMPL-X model file such as SMPLX_NEUTRAL_2020"),
    ("bad_weights", r"foo\.npz: 'weights' has shape \(10, 55\), expected \(\d+, 55\)"),
    ("no_vertex_ids", r"foo\.npz has \d+ vertices and no 'vertex_id_names'"),
])
def test_bad_files_name_the_file_and_the_problem(tmp_path, case, pattern):
    path = {
        "missing": lambda: str(tmp_path / "nothere.npz"),
        "directory": lambda: str(tmp_path),
        "not_npz": lambda: (tmp_path / "notnpz.npz").write_text("hello") and str(tmp_path / "notnpz.npz"),
        "no_regressor": lambda: _bad(tmp_path, J_regressor=None),
        "bad_weights": lambda: _bad(tmp_path, weights=np.ones((10, 55))),
        "no_vertex_ids": lambda: _bad(tmp_path, vertex_id_names=None),
    }[case]()
    with pytest.raises(BodyModelError, match=pattern):
        load_body_model(path)
    assert issubclass(BodyModelError, ValueError)


def test_forward_is_chunked_without_changing_results(mannequin):
    rng = np.random.default_rng(0)
    poses = (rng.normal(size=(7, 165)) * 0.3).astype(np.float32)
    trans = rng.normal(size=(7, 3)).astype(np.float32)
    expr = rng.normal(size=(7, 100)).astype(np.float32)
    a = mannequin.forward(poses, trans, expr, chunk=3)
    b = mannequin.forward(poses, trans, expr, chunk=64)
    assert a.vertices.shape == (7, mannequin.num_vertices, 3) and a.vertices.dtype == np.float32
    assert a.joints.shape == (7, 55, 3)
    np.testing.assert_allclose(a.vertices, b.vertices, atol=1e-6)
    np.testing.assert_allclose(a.vertices.mean(1), trans + mannequin.forward(poses, 0 * trans, expr).vertices.mean(1),
                               atol=1e-5)


def test_real_beat2_frames_put_the_hands_where_the_arms_point(mannequin, take_path):
    from gesturelsm.motion import MotionSequence

    seq = MotionSequence.load(take_path)
    frames = [0, 300, 700, 1500]
    sub = MotionSequence(seq.poses[frames], seq.trans[frames], seq.expressions[frames], seq.betas)
    out = mannequin.forward_sequence(sub)
    rest = mannequin.forward(np.zeros_like(sub.poses), sub.trans, sub.expressions, sub.betas)
    assert np.abs(out.vertices - rest.vertices).max() > 0.3       # arms come down from the T-pose
    owner = mannequin.module.lbs_weights.numpy().argmax(1)
    for side in ("left", "right"):
        hand_joints = [JI[f"{side}_wrist"]] + [j for j, n in enumerate(JOINT_NAMES) if n.startswith(side) and
                                               n[len(side) + 1:-1] in ("index", "middle", "ring", "pinky", "thumb")]
        assert len(hand_joints) == 16
        hand = np.isin(owner, hand_joints)
        wrist, elbow = out.joints[:, JI[f"{side}_wrist"]], out.joints[:, JI[f"{side}_elbow"]]
        forearm = (wrist - elbow) / np.linalg.norm(wrist - elbow, axis=1, keepdims=True)
        centroid = out.vertices[:, hand].mean(1)
        ahead = ((centroid - wrist) * forearm).sum(1)
        assert (ahead > 0.03).all(), (side, ahead)                 # beyond the wrist, along the forearm
        assert (np.linalg.norm(centroid - wrist, axis=1) < 0.10).all()
    # standing on the floor: the lowest point is within a few centimetres of y = 0
    assert np.abs(out.vertices[:, :, 1].min(1)).max() < 0.05


@pytest.mark.parametrize("which", ["mannequin", "synthetic"])
def test_forward_subset_equals_forward_on_those_vertices(which, mannequin, synthetic_smplx_dir):
    """Pose correctives included: the synthetic file has non-zero posedirs, the mannequin none."""
    body = mannequin if which == "mannequin" else load_body_model(synthetic_smplx_dir)
    rng = np.random.default_rng(1)
    poses = (rng.normal(size=(5, 165)) * 0.3).astype(np.float32)
    expr, betas = rng.normal(size=(5, 100)), rng.normal(size=10)
    idx = rng.choice(body.num_vertices, 40, replace=False)
    full = body.forward(poses, np.zeros((5, 3)), expr, betas).vertices[:, idx]
    np.testing.assert_allclose(body.forward_subset(idx, poses, expr, betas), full, atol=2e-5)
