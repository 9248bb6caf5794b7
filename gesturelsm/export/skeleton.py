"""What the exports share: animator-facing joint names, the rest skeleton of a body, leaf end points.

Names: SMPL-X's 55 joints renamed to the Mixamo / BEAT v1 convention (Hips, Spine, LeftUpLeg, LeftArm,
LeftHandIndex1, ...) that Blender's retargeting add-ons, Unity's Humanoid auto-mapping and most BVH tools
recognise; `names="smplx"` keeps SMPL-X's own names. Rest pose = SMPL-X's T-pose: every joint frame is
aligned with the world (y up, the body faces +z, its left is +x), so a joint's local rotation in the
exports is exactly its SMPL-X axis-angle rotation.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..motion.skeleton import JOINT_NAMES, NUM_JOINTS, PARENTS

_BODY = {
    "pelvis": "Hips", "left_hip": "LeftUpLeg", "right_hip": "RightUpLeg", "spine1": "Spine",
    "left_knee": "LeftLeg", "right_knee": "RightLeg", "spine2": "Spine1", "left_ankle": "LeftFoot",
    "right_ankle": "RightFoot", "spine3": "Spine2", "left_foot": "LeftToeBase", "right_foot": "RightToeBase",
    "neck": "Neck", "left_collar": "LeftShoulder", "right_collar": "RightShoulder", "head": "Head",
    "left_shoulder": "LeftArm", "right_shoulder": "RightArm", "left_elbow": "LeftForeArm",
    "right_elbow": "RightForeArm", "left_wrist": "LeftHand", "right_wrist": "RightHand", "jaw": "Jaw",
    "left_eye_smplhf": "LeftEye", "right_eye_smplhf": "RightEye",
}


def _animator_name(name: str) -> str:
    if name in _BODY:
        return _BODY[name]
    side, finger = name.split("_", 1)                       # e.g. left_index2
    return f"{side.capitalize()}Hand{finger[:-1].capitalize()}{finger[-1]}"


ANIMATOR_NAMES: tuple[str, ...] = tuple(_animator_name(n) for n in JOINT_NAMES)
NAME_SETS = {"animator": ANIMATOR_NAMES, "smplx": JOINT_NAMES}
LEAVES: tuple[int, ...] = tuple(j for j in range(NUM_JOINTS) if j not in PARENTS)

# smplx's extra vertex joints, in VertexJointSelector order
EXTRA_NAMES = ("nose", "reye", "leye", "rear", "lear", "LBigToe", "LSmallToe", "LHeel", "RBigToe", "RSmallToe",
               "RHeel", "lthumb", "lindex", "lmiddle", "lring", "lpinky", "rthumb", "rindex", "rmiddle", "rring",
               "rpinky")
_LEAF_TIP = {"left_foot": "LBigToe", "right_foot": "RBigToe", "jaw": None, "left_eye_smplhf": None,
             "right_eye_smplhf": None}
for _s, _c in (("left", "l"), ("right", "r")):
    for _f in ("index", "middle", "ring", "pinky", "thumb"):
        _LEAF_TIP[f"{_s}_{_f}3"] = f"{_c}{_f}"

assert len(set(ANIMATOR_NAMES)) == NUM_JOINTS


def full_poses(seq, body) -> np.ndarray:
    """(T, 165) float64: the rotations the body model actually applies: `seq.poses` plus the model's pose
    mean (SMPL-X's relaxed hand mean when a body was loaded with flat_hand_mean=False; zero by default)."""
    mean = body.module.pose_mean.detach().cpu().numpy().astype(np.float64).reshape(1, -1)
    return seq.poses.astype(np.float64) + mean


def joint_names(names: str) -> tuple[str, ...]:
    if names not in NAME_SETS:
        raise InputError(f"names={names!r}: use 'animator' (Hips, LeftArm, ...) or 'smplx'")
    return NAME_SETS[names]


def extra_vertex_ids(body) -> np.ndarray:
    """(21,) vertex indices of smplx's extra joints (nose, eyes, ears, toes, heels, finger tips)."""
    return body.module.vertex_joint_selector.extra_joints_idxs.cpu().numpy().astype(np.int64)


def rest_pose(body, betas=None):
    """BodyOutput of the unposed (T-pose) body for these betas: the full pose is zero, i.e. the model's pose
    mean (relaxed hands with flat_hand_mean=False) is cancelled."""
    mean = body.module.pose_mean.detach().cpu().numpy().astype(np.float32).reshape(1, -1)
    return body.forward(-mean, np.zeros((1, 3)), betas=betas)


def end_sites(body, betas=None) -> dict[int, np.ndarray]:
    """Leaf joint -> offset (m) of its end point in the rest pose (toe / finger tips from the body's own
    vertices; jaw: 9 cm forward and 4 cm down (chin); eyes: 2 cm forward)."""
    rest = rest_pose(body, betas)
    J, V = rest.joints[0].astype(np.float64), rest.vertices[0].astype(np.float64)
    ids = dict(zip(EXTRA_NAMES, extra_vertex_ids(body)))
    out = {}
    for j in LEAVES:
        tip = _LEAF_TIP.get(JOINT_NAMES[j])
        if tip is not None:
            out[j] = V[ids[tip]] - J[j]
        elif JOINT_NAMES[j] == "jaw":
            out[j] = np.array([0.0, -0.04, 0.09])
        else:
            out[j] = np.array([0.0, 0.0, 0.02])
    return out
