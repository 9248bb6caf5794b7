"""ARKit blendshapes measured on the mannequin's face, head / eye rotations, and the Live Link Face CSV."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gesturelsm.cli import main
from gesturelsm.errors import UserError
from gesturelsm.export import ARKIT_NAMES, arkit_face, export_arkit, read_live_link_csv
from gesturelsm.export.arkit import EYE_LOOK_FULL, JAW_SIDE
from gesturelsm.export.live_link import timecode, timecode_frame, write_live_link_csv
from gesturelsm.motion import MotionSequence
from gesturelsm.motion.skeleton import JOINT_INDEX
from gesturelsm.export.alive import EYE_NEUTRAL, HEAD_NEUTRAL, JAW_FULL

# the header of a Live Link Face take's CSV, as the app writes it
LIVE_LINK_HEADER = (
    "Timecode,BlendShapeCount,EyeBlinkLeft,EyeLookDownLeft,EyeLookInLeft,EyeLookOutLeft,EyeLookUpLeft,"
    "EyeSquintLeft,EyeWideLeft,EyeBlinkRight,EyeLookDownRight,EyeLookInRight,EyeLookOutRight,EyeLookUpRight,"
    "EyeSquintRight,EyeWideRight,JawForward,JawRight,JawLeft,JawOpen,MouthClose,MouthFunnel,MouthPucker,MouthRight,"
    "MouthLeft,MouthSmileLeft,MouthSmileRight,MouthFrownLeft,MouthFrownRight,MouthDimpleLeft,MouthDimpleRight,"
    "MouthStretchLeft,MouthStretchRight,MouthRollLower,MouthRollUpper,MouthShrugLower,MouthShrugUpper,"
    "MouthPressLeft,MouthPressRight,MouthLowerDownLeft,MouthLowerDownRight,MouthUpperUpLeft,MouthUpperUpRight,"
    "BrowDownLeft,BrowDownRight,BrowInnerUp,BrowOuterUpLeft,BrowOuterUpRight,CheekPuff,CheekSquintLeft,"
    "CheekSquintRight,NoseSneerLeft,NoseSneerRight,TongueOut,HeadYaw,HeadPitch,HeadRoll,LeftEyeYaw,LeftEyePitch,"
    "LeftEyeRoll,RightEyeYaw,RightEyePitch,RightEyeRoll")


def _motion(T: int, joints: dict[str, np.ndarray] | None = None, expressions: dict[int, float] | None = None
            ) -> MotionSequence:
    """T frames at rest; `joints` {name: (T, 3) or (3,) axis-angle}, `expressions` {index: value} on every frame."""
    poses, ex = np.zeros((T, 165)), np.zeros((T, 100))
    for name, aa in (joints or {}).items():
        j = 3 * JOINT_INDEX[name]
        poses[:, j:j + 3] = aa
    for k, v in (expressions or {}).items():
        ex[:, k] = v
    return MotionSequence(poses, np.tile([0.0, 1.3, 0.0], (T, 1)), ex)


def test_neutral_face_gives_no_blendshapes_and_no_rotation(body):
    face = arkit_face(_motion(2), body, neutral=False)
    assert face.weights.shape == (2, 52) and face.head.shape == (2, 3) and face.eyes.shape == (2, 6)
    assert face.weights.max() < 0.02
    assert np.abs(face.head).max() < 1e-9 and np.abs(face.eyes).max() < 1e-9


def test_the_speakers_neutral_head_and_eyes_read_zero(body):
    """Angles are relative to the speaker's own neutral (alive.py): the head posed at it reads 0, the rest pose's
    upright head reads the neutral's inverse (the speaker looks 15 degrees down: upright is 'up')."""
    head = HEAD_NEUTRAL.as_rotvec()
    eyes = {"left_eye_smplhf": EYE_NEUTRAL[0].as_rotvec(), "right_eye_smplhf": EYE_NEUTRAL[1].as_rotvec()}
    face = arkit_face(_motion(2, {"head": head, **eyes}), body)
    assert np.abs(face.head).max() < 1e-6 and np.abs(face.eyes).max() < 1e-6
    upright = arkit_face(_motion(1), body)
    np.testing.assert_allclose(upright.head[0], HEAD_NEUTRAL.inv().as_euler("YXZ"), atol=1e-9)
    assert upright.head[0, 1] < -0.2


def test_jaw_opening_raises_jaw_open_to_one_and_nothing_else(body):
    angles = np.linspace(0.0, JAW_FULL, 8)
    face = arkit_face(_motion(8, {"jaw": np.stack([angles, 0 * angles, 0 * angles], -1)}), body, neutral=False)
    jaw_open = face.weight("JawOpen")
    assert jaw_open[0] < 0.02 and jaw_open[-1] == pytest.approx(1.0, abs=0.02)
    assert (np.diff(jaw_open) > 0.05).all(), jaw_open
    others = np.delete(face.weights, ARKIT_NAMES.index("JawOpen"), axis=1)    # MouthClose, Smile, JawLeft ...
    assert others.max() < 0.02, [n for n, w in zip(ARKIT_NAMES, face.weights.max(0)) if n != "JawOpen" and w >= 0.02]


def test_smile_expression_raises_both_corners_alike_and_no_frown(body):
    face = arkit_face(_motion(1, expressions={1: 2.0}), body)
    left, right = face.weight("MouthSmileLeft")[0], face.weight("MouthSmileRight")[0]
    assert left > 0.4 and right > 0.4 and abs(left - right) < 0.15 * max(left, right)
    assert face.weight("MouthFrownLeft")[0] < 0.02 and face.weight("MouthFrownRight")[0] < 0.02
    assert face.weight("JawOpen")[0] < 0.02 and face.weight("BrowInnerUp")[0] < 0.02


def test_brow_expression_raises_inner_and_outer_brows(body):
    face = arkit_face(_motion(1, expressions={2: 3.0}), body)
    for name in ("BrowInnerUp", "BrowOuterUpLeft", "BrowOuterUpRight"):
        assert face.weight(name)[0] > 0.4, name
    for name in ("BrowDownLeft", "BrowDownRight", "MouthSmileLeft", "JawOpen"):
        assert face.weight(name)[0] < 0.02, name
    down = arkit_face(_motion(1, expressions={2: -3.0}), body)             # the field reversed lowers them
    assert down.weight("BrowDownLeft")[0] > 0.4 and down.weight("BrowInnerUp")[0] < 0.02


def test_jaw_turned_about_the_vertical_gives_jaw_left_xor_right_by_sign(body):
    """+y rotation swings the chin to +x, the face's own left: JawLeft."""
    face = arkit_face(_motion(2, {"jaw": np.array([[0.0, 0.1, 0], [0, -0.1, 0]])}), body)
    left, right = face.weight("JawLeft"), face.weight("JawRight")
    assert left[0] == pytest.approx(0.1 / JAW_SIDE, abs=0.1) and right[0] == 0.0
    assert right[1] == pytest.approx(0.1 / JAW_SIDE, abs=0.1) and left[1] == 0.0
    assert face.weight("JawOpen").max() < 0.02


def test_head_rotation_sign_and_size_relative_to_the_body_facing(body):
    T = 4
    head, neck, pelvis = np.zeros((T, 3)), np.zeros((T, 3)), np.zeros((T, 3))
    head[0] = [0, 0.3, 0]                                              # head turned to its left
    neck[1], head[1] = [0, 0.2, 0], [0, 0.1, 0]                        # neck and head share the turn
    pelvis[2], head[2] = [0, 1.0, 0], [0, 0.3, 0]                      # whole body turned: only the head counts
    head[3] = Rotation.from_euler("YXZ", [0.3, 0.2, 0.1]).as_rotvec()  # yaw, pitch (down), roll
    face = arkit_face(_motion(T, {"head": head, "neck": neck, "pelvis": pelvis}), body, neutral=False)
    np.testing.assert_allclose(face.head[:3], [[0.3, 0, 0]] * 3, atol=1e-9)
    np.testing.assert_allclose(face.head[3], [0.3, 0.2, 0.1], atol=1e-9)
    nose = Rotation.from_rotvec(head[3]).apply([0.0, 0, 1])            # pitch > 0 looks down, yaw > 0 to +x
    assert nose[1] < 0 and nose[0] > 0


def test_eye_joints_give_eye_rotations_and_look_weights(body):
    eye = np.array([0.0, 0.2, 0.0])                                    # both eyes turned to the face's left
    face = arkit_face(_motion(1, {"left_eye_smplhf": eye, "right_eye_smplhf": eye}), body, neutral=False)
    np.testing.assert_allclose(face.eyes[0], [0.2, 0, 0, 0.2, 0, 0], atol=1e-9)
    assert face.weight("EyeLookOutLeft")[0] == pytest.approx(0.2 / EYE_LOOK_FULL)   # left eye looks outward
    assert face.weight("EyeLookInRight")[0] == pytest.approx(0.2 / EYE_LOOK_FULL)   # right eye towards the nose
    assert face.weight("EyeLookInLeft")[0] == 0 and face.weight("EyeLookOutRight")[0] == 0


def test_wild_motion_weights_stay_in_unit_range(body, wild_motion):
    face = arkit_face(wild_motion, body)
    assert np.isfinite(face.weights).all() and face.weights.min() >= 0 and face.weights.max() <= 1
    assert face.weights.max() > 0.5                                    # the wild jaw and expressions move the face


def test_csv_layout_timecodes_and_round_trip(tmp_path, body, wild_motion):
    face = arkit_face(wild_motion, body)
    path = write_live_link_csv(face, tmp_path / "face.csv")
    lines = path.read_text().splitlines()
    assert lines[0] == LIVE_LINK_HEADER and len(lines) == 1 + wild_motion.num_frames
    rows = [ln.split(",") for ln in lines[1:]]
    assert all(len(r) == 2 + 61 and r[1] == "61" for r in rows)
    assert rows[0][0] == "00:00:00:00.000"
    np.testing.assert_array_equal(np.diff([timecode_frame(r[0], 30) for r in rows]), 1.0)
    back = read_live_link_csv(path, fps=30)
    np.testing.assert_allclose(back.weights, face.weights, atol=5e-7)
    np.testing.assert_allclose(back.head, face.head, atol=5e-7)
    np.testing.assert_allclose(back.eyes, face.eyes, atol=5e-7)
    assert back.timecodes == tuple(r[0] for r in rows)


def test_timecodes_carry_seconds_minutes_and_hours():
    assert timecode(31, 30) == "00:00:01:01.000" and timecode(60 * 60 * 25 + 59, 60) == "00:25:00:59.000"
    assert timecode(3600 * 30 + 61 * 30 + 2, 30) == "01:01:01:02.000"
    for f in (0, 29, 30, 1799, 3600 * 30 + 7):
        assert timecode_frame(timecode(f, 30), 30) == f
    assert timecode_frame("14:03:52:28.207", 60) == pytest.approx((14 * 3600 + 3 * 60 + 52) * 60 + 28.207)


def test_reader_finds_columns_by_name_and_rejects_other_files(tmp_path):
    names = list(reversed(ARKIT_NAMES))                                # another order, ARKit's camelCase
    header = ["Timecode", "BlendShapeCount"] + [n[0].lower() + n[1:] for n in names] + ["HeadYaw"]
    values = np.linspace(0, 1, 52)
    (tmp_path / "other.csv").write_text(",".join(header) + "\n00:00:00:00.000,53,"
                                        + ",".join(f"{v:.4f}" for v in values[::-1]) + ",0.25\n")
    face = read_live_link_csv(tmp_path / "other.csv")
    np.testing.assert_allclose(face.weights[0], values, atol=1e-4)
    assert face.head[0].tolist() == [0.25, 0, 0] and face.eyes.shape == (1, 6)
    (tmp_path / "bad.csv").write_text("frame,JawOpen\n0,0.5\n")
    with pytest.raises(UserError, match="not a Live Link Face CSV"):
        read_live_link_csv(tmp_path / "bad.csv")
    (tmp_path / "cut.csv").write_text(",".join(header) + "\n00:00:00:00.000,53,0.5\n")
    with pytest.raises(UserError, match="row 2"):
        read_live_link_csv(tmp_path / "cut.csv")
    with pytest.raises(UserError, match="cannot read"):
        read_live_link_csv(tmp_path / "missing.csv")


def test_export_arkit_cli_writes_the_file_and_refuses_bad_paths(tmp_path, body, capsys):
    seq = _motion(3, {"jaw": np.array([0.2, 0, 0])}, {1: 1.0})
    src = seq.save(tmp_path / "in.npz")
    out = tmp_path / "faces" / "take_face.csv"
    assert main(["export", str(src), "--arkit", str(out)]) == 0
    face = read_live_link_csv(out)
    np.testing.assert_allclose(face.weights, arkit_face(seq, body).weights, atol=5e-7)
    assert face.weight("JawOpen")[0] > 0.3 and face.weight("MouthSmileLeft")[0] > 0.1
    capsys.readouterr()
    (tmp_path / "file.txt").write_text("")
    for bad, says in ((tmp_path / "face.txt", ".csv"), (tmp_path / "file.txt" / "face.csv", "cannot write")):
        assert main(["export", str(src), "--arkit", str(bad)]) == 2
        err = capsys.readouterr().err.strip()
        assert says in err and "\n" not in err and "Traceback" not in err
    with pytest.raises(UserError, match=".csv"):
        export_arkit(seq, tmp_path / "face.json", body=body)


def test_real_take_face_moves_with_speech(beat2_root, real_motion, body):
    seq = real_motion.slice(0, 300)
    face = arkit_face(seq, body)
    assert face.weights.min() >= 0 and face.weights.max() <= 1
    jaw = face.weight("JawOpen")
    assert jaw.std() > 0.02 and jaw.max() > 0.1                        # the jaw moves while the speaker talks
    assert np.abs(face.head).max() < np.pi / 2                         # a speaker's head stays within a quarter turn


def test_head_orientation_is_the_posed_face_s_on_a_real_take(beat2_root, real_motion, body):
    """Oracle: the rotation carrying the rest face's rigid landmarks (brows, nose, eyes) onto the posed body's is
    the head joint's world orientation that HeadYaw/Pitch/Roll are read from."""
    from gesturelsm.export.arkit import global_rotations
    from gesturelsm.export.keypoints import keypoints_3d

    seq = real_motion.slice(0, 20)
    posed = keypoints_3d(seq, body)["face"][:, 17:48]
    rest_seq = MotionSequence(np.zeros((1, 165)), np.zeros((1, 3)), np.zeros((1, 100)), seq.betas)
    rest = keypoints_3d(rest_seq, body)["face"][0, 17:48]
    head = global_rotations(seq.poses, "head")
    for t in range(seq.num_frames):
        mesh, _ = Rotation.align_vectors(posed[t] - posed[t].mean(0), rest - rest.mean(0))
        assert np.degrees((mesh * head[t].inv()).magnitude()) < 0.5
