"""The VMC sender: bundles decoded by an independent OSC decoder, bone names, unit quaternions, a T-pose frame as
identity, and the received local rotations put back on a T-pose skeleton pointing the limbs where the motion does
(Unity's left-handed frame included)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from _osc import decode_bundle
from gesturelsm.body.model import resolve_body
from gesturelsm.export.vmc import HUMAN_BODY_BONES, UNITY_BONE, VRM_PRESETS, tpose_skeleton, vmc_bundle, vmc_frames
from gesturelsm.export.arkit import ARKIT_NAMES
from gesturelsm.motion import MotionSequence
from gesturelsm.motion.skeleton import JOINT_INDEX, JOINT_NAMES, PARENTS

# Unity's HumanBodyBones enum, written out independently of the module (UnityEngine.HumanBodyBones, LastBone excluded)
UNITY_ENUM = """Hips LeftUpperLeg RightUpperLeg LeftLowerLeg RightLowerLeg LeftFoot RightFoot Spine Chest Neck Head
LeftShoulder RightShoulder LeftUpperArm RightUpperArm LeftLowerArm RightLowerArm LeftHand RightHand LeftToes RightToes
LeftEye RightEye Jaw LeftThumbProximal LeftThumbIntermediate LeftThumbDistal LeftIndexProximal LeftIndexIntermediate
LeftIndexDistal LeftMiddleProximal LeftMiddleIntermediate LeftMiddleDistal LeftRingProximal LeftRingIntermediate
LeftRingDistal LeftLittleProximal LeftLittleIntermediate LeftLittleDistal RightThumbProximal RightThumbIntermediate
RightThumbDistal RightIndexProximal RightIndexIntermediate RightIndexDistal RightMiddleProximal
RightMiddleIntermediate RightMiddleDistal RightRingProximal RightRingIntermediate RightRingDistal RightLittleProximal
RightLittleIntermediate RightLittleDistal UpperChest""".split()
# limbs whose direction the test compares: (from joint, to joint), SMPL-X names
LIMBS = [(f"{s}_{a}", f"{s}_{b}") for s in ("left", "right") for a, b in
         (("shoulder", "elbow"), ("elbow", "wrist"), ("hip", "knee"), ("knee", "ankle"), ("collar", "shoulder"),
          ("index1", "index2"), ("thumb1", "thumb2"), ("middle2", "middle3"))] + [("spine3", "neck"), ("neck", "head")]


def decoded(frames, t: int = 0) -> dict:
    msgs = decode_bundle(vmc_bundle(frames, t, t / frames.fps))
    out = {"addresses": [m[0] for m in msgs], "bones": {}, "blends": {}, "root": None, "T": None}
    for address, args in msgs:
        if address == "/VMC/Ext/Bone/Pos":
            out["bones"][args[0]] = (np.array(args[1:4]), np.array(args[4:8]))
        elif address == "/VMC/Ext/Blend/Val":
            out["blends"][args[0]] = args[1]
        elif address == "/VMC/Ext/Root/Pos":
            out["root"] = args
        elif address == "/VMC/Ext/T":
            out["T"] = args[0]
    return out


def smplx_directions(seq: MotionSequence, body) -> np.ndarray:
    """(T, L, 3) the motion's limb directions by SMPL-X forward kinematics (numpy), body frame."""
    rest = np.asarray(body.rest_joints(), np.float64)
    aa = np.asarray(seq.poses, np.float64).reshape(len(seq.poses), 55, 3)
    T = len(aa)
    G = np.zeros((T, 55, 3, 3))
    P = np.zeros((T, 55, 3))
    for j, p in enumerate(PARENTS):
        R = Rotation.from_rotvec(aa[:, j]).as_matrix()
        if p < 0:
            G[:, j], P[:, j] = R, rest[j]
        else:
            G[:, j] = G[:, p] @ R
            P[:, j] = P[:, p] + G[:, p] @ (rest[j] - rest[p])
    d = np.stack([P[:, JOINT_INDEX[b]] - P[:, JOINT_INDEX[a]] for a, b in LIMBS], 1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def received_directions(bones_per_frame: list[dict]) -> np.ndarray:
    """(T, L, 3) limb directions from the received local positions and rotations, by forward kinematics in
    Unity's own left-handed frame (quaternion products as Unity's), then mirrored to the body's frame."""
    parent_bone = {UNITY_BONE[j]: (UNITY_BONE[JOINT_NAMES[p]] if p >= 0 else None)
                   for j, p in zip(JOINT_NAMES, PARENTS)}
    out = []
    for bones in bones_per_frame:
        Gw, Pw = {}, {}
        for j in JOINT_NAMES:
            name = UNITY_BONE[j]
            pos, q = bones[name]
            R = Rotation.from_quat(q)
            parent = parent_bone[name]
            if parent is None:
                Gw[name], Pw[name] = R, pos
            else:
                Gw[name] = Gw[parent] * R
                Pw[name] = Pw[parent] + Gw[parent].apply(pos)
        d = np.stack([Pw[UNITY_BONE[b]] - Pw[UNITY_BONE[a]] for a, b in LIMBS])
        d = d * np.array([-1.0, 1.0, 1.0])              # Unity (avatar's left at -x) -> the body's frame
        out.append(d / np.linalg.norm(d, axis=-1, keepdims=True))
    return np.stack(out)


@pytest.fixture(scope="module")
def body():
    return resolve_body(None)


def test_bone_names_are_unitys_humanbodybones():
    assert HUMAN_BODY_BONES == tuple(UNITY_ENUM) and len(UNITY_ENUM) == 55
    assert sorted(UNITY_BONE) == sorted(JOINT_NAMES)


def test_bundle_layout_names_and_unit_quaternions(wild_motion, body):
    frames = vmc_frames(wild_motion, body, perfect_sync=True)
    for t in range(wild_motion.num_frames):
        d = decoded(frames, t)
        a = d["addresses"]
        assert a[0] == "/VMC/Ext/Root/Pos" and d["root"][0] == "root"
        assert a[-3:] == ["/VMC/Ext/Blend/Apply", "/VMC/Ext/OK", "/VMC/Ext/T"]
        assert a.index("/VMC/Ext/Blend/Apply") > max(i for i, x in enumerate(a) if x == "/VMC/Ext/Blend/Val")
        assert set(d["bones"]) == set(UNITY_ENUM) and a.count("/VMC/Ext/Bone/Pos") == 55
        q = np.array([v[1] for v in d["bones"].values()])
        assert np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-5)
        assert set(d["blends"]) == set(VRM_PRESETS) | set(ARKIT_NAMES)
        assert all(0.0 <= v <= 1.0 for v in d["blends"].values())
        assert d["T"] == pytest.approx(t / 30, abs=1e-6)
    plain = decoded(vmc_frames(wild_motion, body))
    assert set(plain["blends"]) == set(VRM_PRESETS)


def test_a_tpose_frame_sends_identity_rotations(body):
    skel = tpose_skeleton(body)
    rest = np.asarray(body.rest_joints())
    arm = rest[JOINT_INDEX["left_elbow"]] - rest[JOINT_INDEX["left_shoulder"]]
    assert np.degrees(np.arccos(arm[0] / np.linalg.norm(arm))) < 1.0      # the mannequin's rest is a T-pose
    assert np.allclose(skel.rotation, np.eye(3))
    seq = MotionSequence(np.zeros((2, 165)), np.zeros((2, 3)), np.zeros((2, 100)))
    d = decoded(vmc_frames(seq, body))
    for name, (_, q) in d["bones"].items():
        assert abs(abs(q[3]) - 1.0) < 1e-5, (name, q)
    # Unity's frame: the avatar's left hand at -x, its head up
    assert d["bones"]["LeftUpperArm"][0][0] < 0 < d["bones"]["RightUpperArm"][0][0]
    assert d["bones"]["Neck"][0][1] > 0


def test_received_rotations_reproduce_the_limb_directions(wild_motion, body):
    frames = vmc_frames(wild_motion, body)
    got = received_directions([decoded(frames, t)["bones"] for t in range(frames.num_frames)])
    want = smplx_directions(wild_motion, body)
    err = np.degrees(np.arccos(np.clip((got * want).sum(-1), -1, 1)))
    assert err.max() < 3.0, {LIMBS[i]: float(err[:, i].max()) for i in range(len(LIMBS))}


def test_a_mirrored_send_would_fail_the_direction_test(wild_motion, body):
    """The check above sees handedness: the same rotations without Unity's conversion point limbs elsewhere."""
    frames = vmc_frames(wild_motion, body)
    frames.rotations = frames.rotations * np.array([1.0, -1.0, -1.0, 1.0])     # undo the conversion
    got = received_directions([decoded(frames, t)["bones"] for t in range(frames.num_frames)])
    err = np.degrees(np.arccos(np.clip((got * smplx_directions(wild_motion, body)).sum(-1), -1, 1)))
    assert err.max() > 20.0
