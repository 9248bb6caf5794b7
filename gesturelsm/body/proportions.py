"""Body proportions of the built-in mannequin, measured once from real motion-capture data.

Source: the BEAT v1 BVH of the same take as the BEAT2 sample (`beat_v1/2_scott_0_1_1.bvh`: speaker 2
"scott", 75 joints, centimetres, y up, the body faces +z, its left is +x: the same axes as SMPL-X).
Only the skeleton's OFFSETs are read (its rest pose); left and right are averaged (mirrored) so the
mannequin is symmetric. The numbers are baked below as constants so the product needs no data files;
`derive_proportions(bvh)` re-measures them and a test checks both agree.

BVH joint -> SMPL-X joint (see assets/body/MANNEQUIN.md for the table of lengths):

    Spine -> pelvis           LeftUpLeg -> left_hip       LeftLeg -> left_knee     LeftFoot -> left_ankle
    Spine1 -> spine1          LeftToeBase -> left_foot    (LeftToeBaseEnd = toe tip)
    Spine2 -> spine2          Spine3 -> spine3            Neck -> neck             Head -> head
    (the BVH root Hips sits at the hip joints' height; SMPL-X's pelvis joint sits ~9 cm above the hip
     joints, so it maps to the BVH's first lumbar joint Spine (6 cm above). Neck1 is skipped: SMPL-X has
     one neck joint. HeadEnd's End Site = crown of the head.)
    LeftShoulder (on the midline in this BVH) -> left_collar placed COLLAR_FRACTION of the way to LeftArm
    LeftArm -> left_shoulder  LeftForeArm -> left_elbow   LeftHand -> left_wrist
    LeftHand{Index,Middle,Ring,Pinky}{1,2,3} -> left_{index,...}{1,2,3}  ({...}4 = finger tip)
    LeftHandThumb{1,2,3} -> left_thumb{1,2,3}  (LeftHandThumb4 = thumb tip)

Units: metres.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

FINGERS: tuple[str, ...] = ("index", "middle", "ring", "pinky")
COLLAR_FRACTION = 0.4  # collar joint placed 40% of the way from the midline shoulder root to the shoulder

# ---- measured from beat_v1/2_scott_0_1_1.bvh (metres, left side, x = left, y = up, z = forward) ----------
# Each value: the offset of a joint from its parent in the mapped SMPL-X skeleton (rest pose), or a length.
BVH_PROPORTIONS: dict[str, tuple[float, ...]] = {
    "pelvis->left_hip": (0.0825, -0.0627, 0.0226),
    "left_hip->left_knee": (0.0, -0.4283, 0.0),
    "left_knee->left_ankle": (0.0, -0.4317, 0.0),
    "left_ankle->left_foot": (0.0, -0.0256, 0.1002),
    "left_foot->toe_tip": (0.0, 0.0, 0.1454),
    "pelvis->spine1": (0.0, 0.1248, -0.022),
    "spine1->spine2": (0.0, 0.1262, -0.011),
    "spine2->spine3": (0.0, 0.1267, 0.0),
    "spine3->neck": (0.0, 0.1629, 0.0163),
    "neck->head": (0.0, 0.0687, 0.009),
    "head->crown": (0.0, 0.1946, 0.0),
    "spine3->shoulder_root": (0.0, 0.1164, 0.0588),
    "shoulder_root->left_shoulder": (0.1955, 0.0, 0.0),
    "left_shoulder->left_elbow": (0.3062, 0.0, 0.0),
    "left_elbow->left_wrist": (0.2546, 0.0, 0.0),
    # fingers: (wrist->knuckle distance, proximal, middle, distal phalanx lengths)
    "index": (0.0941, 0.0476, 0.0285, 0.0175),
    "middle": (0.0933, 0.0493, 0.0318, 0.0192),
    "ring": (0.0864, 0.0459, 0.0311, 0.0191),
    "pinky": (0.0796, 0.0371, 0.0237, 0.0176),
    # thumb: offsets (x, y, z) wrist->thumb1, thumb1->thumb2, thumb2->thumb3, thumb3->tip
    "left_wrist->left_thumb1": (0.0042, -0.01, 0.0179),
    "left_thumb1->left_thumb2": (0.0546, 0.0084, 0.0226),
    "left_thumb2->left_thumb3": (0.0359, 0.0055, 0.0149),
    "left_thumb3->thumb_tip": (0.0219, 0.0034, 0.0091),
}


def parse_bvh_offsets(path: str | Path) -> tuple[dict[str, np.ndarray], dict[str, str | None]]:
    """Read a BVH HIERARCHY: joint name -> OFFSET (3,) in file units, and joint -> parent name.

    End Sites are named `<parent>_End`.
    """
    offsets: dict[str, np.ndarray] = {}
    parents: dict[str, str | None] = {}
    stack: list[str] = []
    pending: str | None = None
    text = Path(path).read_text().split("MOTION")[0]
    for line in text.splitlines():
        tok = line.split()
        if not tok:
            continue
        if tok[0] in ("ROOT", "JOINT"):
            pending = tok[1]
        elif tok[0] == "End":
            pending = f"{stack[-1]}_End"
        elif tok[0] == "{":
            assert pending is not None, f"{path}: malformed BVH hierarchy"
            parents[pending] = stack[-1] if stack else None
            stack.append(pending)
            pending = None
        elif tok[0] == "}":
            stack.pop()
        elif tok[0] == "OFFSET":
            offsets[stack[-1]] = np.array([float(v) for v in tok[1:4]])
    return offsets, parents


def _globals(offsets: dict[str, np.ndarray], parents: dict[str, str | None]) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for name in offsets:  # parents appear before children in a BVH file
        p = parents[name]
        out[name] = offsets[name] + (out[p] if p is not None else 0.0)
    return out


def derive_proportions(bvh_path: str | Path, scale: float = 0.01) -> dict[str, tuple[float, ...]]:
    """Re-measure `BVH_PROPORTIONS` from a BEAT v1 BVH (centimetres -> metres, left/right averaged)."""
    offsets, parents = parse_bvh_offsets(bvh_path)
    g = {k: v * scale for k, v in _globals(offsets, parents).items()}
    mirror = np.array([-1.0, 1.0, 1.0])

    def sym(left: str, right: str, ref_l: str | None = None, ref_r: str | None = None) -> np.ndarray:
        """Mean of the left offset and the mirrored right offset (global position differences)."""
        a = g[left] - (g[ref_l] if ref_l else 0.0)
        b = (g[right] - (g[ref_r] if ref_r else 0.0)) * mirror
        return (a + b) / 2

    def rnd(v: np.ndarray | float) -> tuple[float, ...]:
        return tuple(float(x) + 0.0 for x in np.round(np.atleast_1d(v), 4))

    d: dict[str, tuple[float, ...]] = {}
    d["pelvis->left_hip"] = rnd(sym("LeftUpLeg", "RightUpLeg", "Spine", "Spine"))
    d["left_hip->left_knee"] = rnd(sym("LeftLeg", "RightLeg", "LeftUpLeg", "RightUpLeg"))
    d["left_knee->left_ankle"] = rnd(sym("LeftFoot", "RightFoot", "LeftLeg", "RightLeg"))
    d["left_ankle->left_foot"] = rnd(sym("LeftToeBase", "RightToeBase", "LeftFoot", "RightFoot"))
    d["left_foot->toe_tip"] = rnd(sym("LeftToeBaseEnd", "RightToeBaseEnd", "LeftToeBase", "RightToeBase"))
    for a, b, key in (("Spine", "Spine1", "pelvis->spine1"), ("Spine1", "Spine2", "spine1->spine2"),
                      ("Spine2", "Spine3", "spine2->spine3"), ("Spine3", "Neck", "spine3->neck"),
                      ("Neck", "Head", "neck->head"), ("Head", "HeadEnd_End", "head->crown"),
                      ("Spine3", "LeftShoulder", "spine3->shoulder_root")):
        d[key] = rnd(g[b] - g[a])
    d["shoulder_root->left_shoulder"] = rnd(sym("LeftArm", "RightArm", "LeftShoulder", "RightShoulder"))
    d["left_shoulder->left_elbow"] = rnd(sym("LeftForeArm", "RightForeArm", "LeftArm", "RightArm"))
    d["left_elbow->left_wrist"] = rnd(sym("LeftHand", "RightHand", "LeftForeArm", "RightForeArm"))
    for f in FINGERS:
        F = f.capitalize()

        def seg(i: int, j: int | None) -> float:
            lo = [g[f"{s}Hand{F}{i}"] - (g[f"{s}Hand"] if j is None else g[f"{s}Hand{F}{j}"])
                  for s in ("Left", "Right")]
            return float(np.mean([np.linalg.norm(v) for v in lo]))

        d[f] = rnd(np.array([seg(1, None), seg(2, 1), seg(3, 2), seg(4, 3)]))
    chain = ["Hand", "HandThumb1", "HandThumb2", "HandThumb3", "HandThumb4"]
    keys = ["left_wrist->left_thumb1", "left_thumb1->left_thumb2", "left_thumb2->left_thumb3",
            "left_thumb3->thumb_tip"]
    for k, (a, b) in zip(keys, zip(chain[:-1], chain[1:])):
        d[k] = rnd(sym(f"Left{b}", f"Right{b}", f"Left{a}", f"Right{a}"))
    return d


def bvh_joint_names(bvh_path: str | Path) -> list[str]:
    """All ROOT/JOINT names of a BVH file, in file order."""
    text = Path(bvh_path).read_text().split("MOTION")[0]
    return re.findall(r"(?:ROOT|JOINT)\s+(\S+)", text)
