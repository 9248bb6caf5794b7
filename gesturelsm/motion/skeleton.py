"""The SMPL-X kinematic tree: 55 joints, their names, parents and left/right pairs.

Joint order is SMPL-X's (and BEAT2's `poses` column order: joint j occupies columns 3j..3j+2).
Coordinates are metres, y up, the body faces +z, its left side is +x.
"""
from __future__ import annotations

JOINT_NAMES: tuple[str, ...] = (
    "pelvis", "left_hip", "right_hip", "spine1", "left_knee", "right_knee", "spine2",
    "left_ankle", "right_ankle", "spine3", "left_foot", "right_foot", "neck",
    "left_collar", "right_collar", "head", "left_shoulder", "right_shoulder",
    "left_elbow", "right_elbow", "left_wrist", "right_wrist", "jaw", "left_eye_smplhf",
    "right_eye_smplhf",
    "left_index1", "left_index2", "left_index3", "left_middle1", "left_middle2", "left_middle3",
    "left_pinky1", "left_pinky2", "left_pinky3", "left_ring1", "left_ring2", "left_ring3",
    "left_thumb1", "left_thumb2", "left_thumb3",
    "right_index1", "right_index2", "right_index3", "right_middle1", "right_middle2",
    "right_middle3", "right_pinky1", "right_pinky2", "right_pinky3", "right_ring1", "right_ring2",
    "right_ring3", "right_thumb1", "right_thumb2", "right_thumb3",
)
NUM_JOINTS = len(JOINT_NAMES)  # 55
JOINT_INDEX: dict[str, int] = {n: i for i, n in enumerate(JOINT_NAMES)}

PARENTS: tuple[int, ...] = (
    -1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19, 15, 15, 15,
    20, 25, 26, 20, 28, 29, 20, 31, 32, 20, 34, 35, 20, 37, 38,
    21, 40, 41, 21, 43, 44, 21, 46, 47, 21, 49, 50, 21, 52, 53,
)


def _mirror_index(name: str) -> int:
    if name.startswith("left_"):
        return JOINT_INDEX["right_" + name[5:]]
    if name.startswith("right_"):
        return JOINT_INDEX["left_" + name[6:]]
    return JOINT_INDEX[name]


# MIRROR_PERM[j] = the joint that j becomes under a left/right mirror (involution).
MIRROR_PERM: tuple[int, ...] = tuple(_mirror_index(n) for n in JOINT_NAMES)


def children(j: int) -> list[int]:
    return [c for c, p in enumerate(PARENTS) if p == j]


assert NUM_JOINTS == 55 and len(PARENTS) == 55
assert all(PARENTS[j] < j for j in range(1, NUM_JOINTS)), "parents precede children"
assert all(MIRROR_PERM[MIRROR_PERM[j]] == j for j in range(NUM_JOINTS))
