"""BVH: parsed back by an independent reader, the rotations and joint positions come back exactly."""
from __future__ import annotations

import re

import numpy as np
import torch

from gesturelsm.export import ANIMATOR_NAMES, export_bvh
from gesturelsm.export.bvh import continuous_euler, euler_zxy_to_matrix, matrix_to_euler_zxy
from gesturelsm.motion import axis_angle_to_matrix


def read_bvh(path):
    """A small BVH reader written from the format description (not from the writer): joints (name, parent,
    offset, channels), end sites, frame time, motion matrix."""
    tokens = re.findall(r"\S+", path.read_text())
    i = 0
    joints, stack, ends = [], [], 0

    def take():
        nonlocal i
        i += 1
        return tokens[i - 1]

    assert take() == "HIERARCHY"
    while True:
        tok = take()
        if tok in ("ROOT", "JOINT"):
            joints.append({"name": take(), "parent": stack[-1] if stack else -1})
            assert take() == "{"
            stack.append(len(joints) - 1)
            assert take() == "OFFSET"
            joints[-1]["offset"] = np.array([float(take()) for _ in range(3)])
            assert take() == "CHANNELS"
            joints[-1]["channels"] = [take() for _ in range(int(take()))]
        elif tok == "End":
            assert take() == "Site" and take() == "{" and take() == "OFFSET"
            [float(take()) for _ in range(3)]
            assert take() == "}"
            ends += 1
        elif tok == "}":
            stack.pop()
        elif tok == "MOTION":
            break
    assert take() == "Frames:"
    n = int(take())
    assert take() == "Frame" and take() == "Time:"
    dt = float(take())
    width = sum(len(j["channels"]) for j in joints)
    data = np.array([float(x) for x in tokens[i:]]).reshape(n, width)
    return joints, ends, dt, data


def rotations_from(joints, data):
    """(T, J, 3, 3) local rotations and (T, 3) root positions, composing the channels in file order."""
    T = len(data)
    R = np.tile(np.eye(3), (T, len(joints), 1, 1))
    pos = np.zeros((T, 3))
    col = 0
    for j, jt in enumerate(joints):
        for ch in jt["channels"]:
            v = data[:, col]
            col += 1
            if ch.endswith("position"):
                pos[:, "XYZ".index(ch[0])] = v
                continue
            a = np.radians(v)
            c, s = np.cos(a), np.sin(a)
            M = np.tile(np.eye(3), (T, 1, 1))
            p, q = {"X": (1, 2), "Y": (2, 0), "Z": (0, 1)}[ch[0]]
            M[:, p, p], M[:, p, q], M[:, q, p], M[:, q, q] = c, -s, s, c
            R[:, j] = R[:, j] @ M                    # channels compose left to right
    return R, pos


def angle_between(A, B):
    c = (np.trace(np.swapaxes(A, -1, -2) @ B, axis1=-2, axis2=-1) - 1) / 2
    return np.arccos(np.clip(c, -1, 1))


def test_bvh_round_trip_rotations_and_positions(tmp_path, wild_motion, body):
    path = export_bvh(wild_motion, tmp_path / "m.bvh", body=body)
    joints, ends, dt, data = read_bvh(path)
    assert len(joints) == 55 and ends == 15 and abs(dt - 1 / 30) < 1e-6 and len(data) == wild_motion.num_frames
    names = [j["name"] for j in joints]
    assert set(names) == set(ANIMATOR_NAMES) and names[0] == "Hips"
    for n in ("Spine", "Neck", "Head", "LeftArm", "RightForeArm", "LeftHand", "RightHandIndex1", "LeftUpLeg"):
        assert n in names
    assert joints[0]["channels"][:3] == ["Xposition", "Yposition", "Zposition"]
    R, root = rotations_from(joints, data)
    order = [ANIMATOR_NAMES.index(n) for n in names]                  # file order -> SMPL-X joint index
    T = wild_motion.num_frames
    ref = axis_angle_to_matrix(torch.from_numpy(wild_motion.poses.reshape(T, 55, 3)).double()).numpy()[:, order]
    err = angle_between(R, ref)
    assert err.max() < 1e-4, f"max rotation error {err.max():.2e} rad"
    # forward kinematics of the parsed skeleton (cm) = the body model's joints
    world = np.zeros((T, 55, 3))
    G = np.zeros((T, 55, 3, 3))
    for k, jt in enumerate(joints):
        if jt["parent"] < 0:
            G[:, k], world[:, k] = R[:, k], root + jt["offset"]
        else:
            p = jt["parent"]
            G[:, k] = G[:, p] @ R[:, k]
            world[:, k] = world[:, p] + G[:, p] @ jt["offset"]
    ref_j = body.joints(wild_motion.poses, wild_motion.trans, wild_motion.betas)[:, order] * 100
    assert np.abs(world - ref_j).max() < 1e-2, "joint positions agree to 0.1 mm"


def test_bvh_includes_the_body_models_hand_mean(tmp_path, wild_motion, hand_mean_body):
    joints, _, _, data = read_bvh(export_bvh(wild_motion, tmp_path / "h.bvh", body=hand_mean_body))
    R, root = rotations_from(joints, data)
    names = [j["name"] for j in joints]
    k = names.index("LeftHandIndex1")
    T = wild_motion.num_frames
    mean = hand_mean_body.module.pose_mean.numpy().reshape(55, 3)
    ref = axis_angle_to_matrix(torch.from_numpy(wild_motion.poses.reshape(T, 55, 3) + mean).double()).numpy()
    assert angle_between(R[:, k], ref[:, ANIMATOR_NAMES.index("LeftHandIndex1")]).max() < 1e-4
    assert np.abs(mean).max() > 0.1


def test_bvh_units_and_names(tmp_path, wild_motion, body):
    cm = read_bvh(export_bvh(wild_motion.slice(0, 2), tmp_path / "a.bvh", body=body))
    m = read_bvh(export_bvh(wild_motion.slice(0, 2), tmp_path / "b.bvh", body=body, units="m", names="smplx"))
    assert [j["name"] for j in m[0]][:2] == ["pelvis", "left_hip"]
    assert np.allclose(cm[0][1]["offset"], 100 * m[0][1]["offset"], atol=1e-4)
    assert np.allclose(cm[3][:, :3], 100 * m[3][:, :3], atol=1e-3)


def test_euler_helpers_gimbal_and_continuity():
    from scipy.spatial.transform import Rotation

    R = Rotation.random(2000, random_state=1).as_matrix()
    assert np.abs(euler_zxy_to_matrix(matrix_to_euler_zxy(R)) - R).max() < 1e-12
    assert np.allclose(Rotation.from_euler("ZXY", matrix_to_euler_zxy(R)).as_matrix(), R)
    for x in (np.pi / 2, -np.pi / 2, np.pi / 2 - 1e-9):
        G = euler_zxy_to_matrix(np.array([0.4, x, -1.1]))
        assert np.abs(euler_zxy_to_matrix(matrix_to_euler_zxy(G)) - G).max() < 1e-7
    # a joint spinning steadily about z through +-180 deg: no 360-degree jumps, same rotations
    t = np.linspace(0, 4 * np.pi, 200)
    Rz = Rotation.from_euler("z", t[:, None]).as_matrix()[:, None]
    e = continuous_euler(matrix_to_euler_zxy(Rz))
    assert np.abs(np.diff(e, axis=0)).max() < 0.1
    assert np.abs(euler_zxy_to_matrix(e) - Rz).max() < 1e-9
