"""2D keypoints (OpenPose layout, render camera), the BEAT2 npz, and the `gesturelsm export` command."""
from __future__ import annotations

import json

import numpy as np
import pytest

from gesturelsm.cli import main
from gesturelsm.errors import GestureError
from gesturelsm.export import export_keypoints, export_npz, keypoints_2d, npz_bytes
from gesturelsm.motion import MotionSequence
from gesturelsm.render import RenderStyle, fit_camera, render_frames


@pytest.fixture(scope="module")
def standing():
    T = 3
    poses = np.zeros((T, 165))
    poses[:, 3 * 16 + 2], poses[:, 3 * 17 + 2] = -1.1, 1.1                  # arms down
    poses[1, 3 * 18 + 1] = 1.2                                               # left elbow bent in frame 1
    return MotionSequence(poses, np.tile([0.0, 1.3026, 0.0], (T, 1)), np.zeros((T, 100)))


def test_keypoints_inside_image_and_on_the_rendered_body(standing, body):
    kp, cam = keypoints_2d(standing, size=(128, 128), body=body)
    assert kp["body"].shape == (3, 25, 3) and kp["hand_left"].shape == (3, 21, 3) and kp["face"].shape == (3, 70, 3)
    for name in ("body", "hand_left", "hand_right"):
        assert (kp[name][..., 2] == 1).all(), f"{name}: every point is in the image"
        assert (kp[name][..., 0] >= 0).all() and (kp[name][..., 0] < 128).all()
        assert (kp[name][..., 1] >= 0).all() and (kp[name][..., 1] < 128).all()
    assert (kp["face"][:, :17] == 0).all() and (kp["face"][:, 17:, 2] == 1).all()
    # same camera as the renderer: body keypoints fall on body pixels
    assert cam == fit_camera([standing], style=RenderStyle(size=(128, 128)))
    bare = RenderStyle(size=(128, 128), floor="none", shadow=False, background="#000000")
    img = render_frames([standing], [0, 1], style=bare, camera=cam)
    for f in (0, 1):
        mask = img[f].max(-1) > 0
        pts = kp["body"][f, [1, 2, 3, 4, 5, 6, 7, 8, 10, 13]].astype(int)     # neck, arms, pelvis, knees
        near = [mask[max(0, y - 1):y + 2, max(0, x - 1):x + 2].any() for x, y, _ in pts]
        assert all(near), f"frame {f}: keypoints off the rendered body"
    # the bent elbow moves the left wrist keypoint
    assert np.linalg.norm(kp["body"][1, 7, :2] - kp["body"][0, 7, :2]) > 5


def test_keypoint_files(tmp_path, standing, body):
    folder = export_keypoints(standing, tmp_path / "kp", size=(96, 64), body=body)
    files = sorted(folder.glob("*.json"))
    assert [f.name for f in files] == [f"kp_{t:012d}_keypoints.json" for t in range(3)]
    fr = json.loads(files[0].read_text())
    person = fr["people"][0]
    assert fr["version"] == 1.3 and fr["canvas_width"] == 96 and fr["canvas_height"] == 64
    assert len(person["pose_keypoints_2d"]) == 75 and len(person["hand_left_keypoints_2d"]) == 63
    assert len(person["hand_right_keypoints_2d"]) == 63 and len(person["face_keypoints_2d"]) == 210
    one = json.loads(export_keypoints(standing, tmp_path / "all.json", size=(96, 64), body=body).read_text())
    assert one["fps"] == 30 and len(one["frames"]) == 3 and one["frames"][0] == fr


def test_keypoints_are_streamed_in_chunks_and_a_problem_part_way_leaves_nothing(tmp_path, body, monkeypatch):
    """export_keypoints makes and writes STREAM_FRAMES frames at a time (memory bounded whatever the length: the
    one-hour export peaked at 1.88 GB holding every frame's keypoints): the same numbers as keypoints_2d over the
    whole motion; a non-finite keypoint in a later chunk removes what was written (file or folder)."""
    from gesturelsm.export import keypoints as kmod

    from _support import synthetic_motion

    seq = synthetic_motion(frames=7, seed=2)
    monkeypatch.setattr(kmod, "STREAM_FRAMES", 3)
    monkeypatch.setattr(kmod.keypoints_2d_chunks, "__defaults__", (None, 3))
    whole, cam = keypoints_2d(seq, size=(96, 64), body=body)
    chunks = list(kmod.keypoints_2d_chunks(seq, cam, body))
    assert [len(c["body"]) for c in chunks] == [3, 3, 1]
    for k in whole:
        assert np.allclose(np.concatenate([c[k] for c in chunks]), whole[k], atol=1e-4)    # float32 batches
    doc = json.loads(export_keypoints(seq, tmp_path / "all.json", size=(96, 64), body=body).read_text())
    assert len(doc["frames"]) == 7
    assert np.allclose(doc["frames"][6]["people"][0]["pose_keypoints_2d"], whole["body"][6].ravel(), atol=0.006)
    project = kmod._project
    calls = []

    def broken_later(pts, camera):                       # the second chunk's projection goes wrong
        calls.append(1)
        out = project(pts, camera)
        if len(calls) == 2:
            out["body"][0, 0, 0] = np.nan
        return out

    monkeypatch.setattr(kmod, "_project", broken_later)
    for name in ("bad.json", "bad_folder"):
        calls.clear()
        with pytest.raises(GestureError, match="body keypoints hold NaN or infinite values; nothing is written"):
            export_keypoints(seq, tmp_path / name, size=(96, 64), body=body)
        assert len(calls) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["all.json"]     # no .part, no folder, no frame files


def test_npz_is_beat2_and_blender_addon_readable(tmp_path, standing):
    p = export_npz(standing, tmp_path / "m.npz")
    with np.load(p, allow_pickle=False) as d:                                # what the SMPL-X add-on does
        for k in ("poses", "trans", "betas", "gender", "mocap_frame_rate", "expressions"):
            assert k in d.files
        assert str(d["gender"]) == "neutral" and int(d["mocap_frame_rate"]) == 30
        assert d["poses"].shape == (3, 165) and d["poses"].dtype == np.float32
    back = MotionSequence.load(p)
    assert np.array_equal(back.poses, standing.poses) and np.array_equal(back.trans, standing.trans)
    bad = MotionSequence(standing.poses.copy(), standing.trans, standing.expressions)
    bad.poses[0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        export_npz(bad, tmp_path / "bad.npz")
    with pytest.raises(ValueError, match=".npz"):
        export_npz(standing, tmp_path / "m.txt")


def test_npz_bytes_are_the_same_npz_and_depend_on_the_motion_only(tmp_path, standing):
    import zipfile

    data = npz_bytes(standing)
    (tmp_path / "b.npz").write_bytes(data)
    with np.load(tmp_path / "b.npz", allow_pickle=False) as got, np.load(export_npz(standing, tmp_path / "a.npz"),
                                                                         allow_pickle=False) as want:
        assert got.files == want.files
        assert all(np.array_equal(got[k], want[k]) and got[k].dtype == want[k].dtype for k in want.files)
    with zipfile.ZipFile(tmp_path / "b.npz") as zf:                        # no time of writing inside
        assert {i.date_time for i in zf.infolist()} == {(1980, 1, 1, 0, 0, 0)}
    assert npz_bytes(MotionSequence(standing.poses, standing.trans, standing.expressions)) == data
    moved = MotionSequence(standing.poses, standing.trans + 0.5, standing.expressions)
    assert npz_bytes(moved) != data
    bad = MotionSequence(standing.poses.copy(), standing.trans, standing.expressions)
    bad.poses[0, 0] = np.inf
    with pytest.raises(ValueError, match="NaN or infinite"):
        npz_bytes(bad)


def test_export_cli(tmp_path, standing, capsys):
    src = standing.save(tmp_path / "in.npz")
    outs = [tmp_path / "o.bvh", tmp_path / "o.glb", tmp_path / "kp", tmp_path / "o.npz"]
    assert main(["export", str(src), "--bvh", str(outs[0]), "--glb", str(outs[1]), "--keypoints", str(outs[2]),
                 "--npz", str(outs[3])]) == 0
    assert all(p.exists() for p in outs) and len(list(outs[2].glob("*.json"))) == 3
    capsys.readouterr()
    assert main(["export", str(src)]) == 2
    assert "nothing to export" in capsys.readouterr().err
    assert main(["export", str(tmp_path / "missing.npz"), "--bvh", str(outs[0])]) == 2


def test_real_beat2_take_exports(tmp_path, real_motion, body):
    from gesturelsm.export import export_bvh, export_glb, read_glb

    seq = real_motion.slice(0, 90)
    kp, _ = keypoints_2d(seq, size=(256, 256), body=body)
    assert (kp["body"][..., 2] == 1).all() and (kp["hand_left"][..., 2] == 1).all()
    text = export_bvh(seq, tmp_path / "r.bvh", body=body).read_text()
    assert "Frames: 90" in text and "ROOT Hips" in text
    gltf, _ = read_glb(export_glb(seq, tmp_path / "r.glb", body=body))
    assert gltf["accessors"][gltf["animations"][0]["samplers"][0]["input"]]["count"] == 90
