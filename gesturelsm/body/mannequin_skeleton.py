"""The mannequin's rest skeleton: the 55 SMPL-X joints laid out in SMPL-X's rest pose.

Rest pose = SMPL-X's: T-pose, arms along +-x, palms down (-y), fingers straight along the arm, the body
faces +z, y up, metres. Bone offsets come from `proportions.BVH_PROPORTIONS` (measured on the BEAT v1
skeleton of the same speaker); what a BVH cannot give (jaw, eyes, knuckle spread across the palm, the
height of the ankle above the sole) is designed here and named as a constant.

Vertical placement: BEAT2 `trans` is the offset added to SMPL-X's rest joints (whose pelvis joint sits
~0.35 m below the origin). The pelvis is put at `y = -MEAN_TRANS_Y + leg_drop()` (= -0.305 m) so that with
the mean BEAT2 translation of the real take the soles are at y = 0 (the floor).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..motion.skeleton import JOINT_INDEX, NUM_JOINTS
from .proportions import BVH_PROPORTIONS, COLLAR_FRACTION, FINGERS

MEAN_TRANS_Y = 1.3026      # mean of trans[:, 1] over beat2/smplxflame_30/2_scott_0_1_1.npz (metres)
ANKLE_HEIGHT = 0.075       # ankle joint above the sole (shoe included); not in the BVH, designed
# knuckle (MCP) centres across the palm, z relative to the wrist (+z = thumb side for the left hand)
KNUCKLE_Z = {"index": 0.0225, "middle": 0.0035, "ring": -0.0150, "pinky": -0.0315}
KNUCKLE_Y = -0.0025        # knuckles slightly below the wrist centre (as in the BVH)
FINGER_SPLAY_DEG = {"index": 4.0, "middle": 0.0, "ring": -5.0, "pinky": -11.0}  # in the palm plane
# thumb: segment lengths from the BVH, root and direction designed (the BVH's in-hand thumb root sits on the
# wrist); the thumb leaves the palm diagonally forward, slightly below the palm plane
THUMB1 = (0.020, -0.010, 0.012)         # thumb1 (carpometacarpal) relative to the wrist, left hand
THUMB_ABDUCTION_DEG, THUMB_TILT_DEG = 32.0, -8.0
# head features relative to the head joint (skull base), metres; x mirrored for the right eye
EYE = (0.032, 0.083, 0.083)             # eyeball centre (left eye)
JAW = (0.0, 0.052, 0.032)               # temporomandibular pivot, in front of the ear canal


def _v(key: str) -> np.ndarray:
    return np.asarray(BVH_PROPORTIONS[key], dtype=np.float64)


@dataclass(frozen=True)
class RestSkeleton:
    joints: np.ndarray                      # (55, 3) rest joint positions, metres
    finger_tips: dict[str, np.ndarray]      # "left_index" -> (3,) tip of the distal phalanx
    toe_tips: dict[str, np.ndarray]         # "left" -> (3,)
    crown: np.ndarray                       # (3,) top of the head
    sole_y: float                           # height of the soles


def leg_drop() -> float:
    """Vertical distance from the pelvis joint to the soles."""
    return float(-_v("pelvis->left_hip")[1] - _v("left_hip->left_knee")[1]
                 - _v("left_knee->left_ankle")[1] + ANKLE_HEIGHT)


def _mirror(p: np.ndarray) -> np.ndarray:
    return p * np.array([-1.0, 1.0, 1.0])


def _rot_y(deg: float) -> np.ndarray:
    """Rotation about y: positive turns +x towards -z (used for finger splay in the palm plane)."""
    a = np.deg2rad(deg)
    return np.array([[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]])


def build_rest_skeleton() -> RestSkeleton:
    J = np.zeros((NUM_JOINTS, 3))
    idx = JOINT_INDEX

    def put(name: str, pos: np.ndarray) -> None:
        J[idx[name]] = pos

    pelvis = np.array([0.0, -MEAN_TRANS_Y + leg_drop(), 0.0])
    put("pelvis", pelvis)
    put("spine1", pelvis + _v("pelvis->spine1"))
    put("spine2", J[idx["spine1"]] + _v("spine1->spine2"))
    put("spine3", J[idx["spine2"]] + _v("spine2->spine3"))
    put("neck", J[idx["spine3"]] + _v("spine3->neck"))
    put("head", J[idx["neck"]] + _v("neck->head"))
    head = J[idx["head"]]
    put("jaw", head + np.array(JAW))
    put("left_eye_smplhf", head + np.array(EYE))
    put("right_eye_smplhf", head + _mirror(np.array(EYE)))

    finger_tips: dict[str, np.ndarray] = {}
    toe_tips: dict[str, np.ndarray] = {}
    for side, m in (("left", 1.0), ("right", -1.0)):
        M = np.array([m, 1.0, 1.0])
        hip = pelvis + _v("pelvis->left_hip") * M
        put(f"{side}_hip", hip)
        put(f"{side}_knee", hip + _v("left_hip->left_knee"))
        put(f"{side}_ankle", J[idx[f"{side}_knee"]] + _v("left_knee->left_ankle"))
        put(f"{side}_foot", J[idx[f"{side}_ankle"]] + _v("left_ankle->left_foot"))
        toe_tips[side] = J[idx[f"{side}_foot"]] + _v("left_foot->toe_tip")

        root = J[idx["spine3"]] + _v("spine3->shoulder_root")
        shoulder = root + _v("shoulder_root->left_shoulder") * M
        put(f"{side}_collar", root + COLLAR_FRACTION * (shoulder - root))
        put(f"{side}_shoulder", shoulder)
        put(f"{side}_elbow", shoulder + _v("left_shoulder->left_elbow") * M)
        wrist = J[idx[f"{side}_elbow"]] + _v("left_elbow->left_wrist") * M
        put(f"{side}_wrist", wrist)

        for f in FINGERS:
            d_mcp, *phalanges = BVH_PROPORTIONS[f]
            z = KNUCKLE_Z[f]
            mcp = np.array([np.sqrt(d_mcp**2 - z**2 - KNUCKLE_Y**2), KNUCKLE_Y, z])
            direction = _rot_y(-FINGER_SPLAY_DEG[f]) @ np.array([1.0, 0.0, 0.0])  # splay towards +-z
            pos = wrist + mcp * M
            for k in range(3):
                put(f"{side}_{f}{k + 1}", pos)
                pos = pos + phalanges[k] * direction * M
            finger_tips[f"{side}_{f}"] = pos
        pos = wrist + np.array(THUMB1) * M
        a, t = np.deg2rad(THUMB_ABDUCTION_DEG), np.deg2rad(THUMB_TILT_DEG)
        thumb_dir = np.array([np.cos(a) * np.cos(t), np.sin(t), np.sin(a) * np.cos(t)])
        for k, key in enumerate(("left_thumb1->left_thumb2", "left_thumb2->left_thumb3",
                                 "left_thumb3->thumb_tip")):
            put(f"{side}_thumb{k + 1}", pos)
            pos = pos + np.linalg.norm(_v(key)) * thumb_dir * M
        finger_tips[f"{side}_thumb"] = pos

    crown = head + _v("head->crown")
    sole_y = float(pelvis[1] - leg_drop())
    return RestSkeleton(J, finger_tips, toe_tips, crown, sole_y)
