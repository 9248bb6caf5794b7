"""Which bone of a character is which SMPL-X joint: the VRM humanoid bone names (0.x and 1.0), the Mixamo /
BEAT v1 names, SMPL-X's own names, and JSON maps for anything else.

A map goes from SMPL-X joint name (`motion.skeleton.JOINT_NAMES`) to the character's bone (node) name. Spine
segments a rig lacks are skipped: a rig with one or two spine bones gets the upper SMPL-X segments
(`spine3`, then `spine1`), so the shoulders always hang from the SMPL-X joint they hang from.
"""
from __future__ import annotations

import json
from pathlib import Path

from ..motion.skeleton import JOINT_NAMES
from .errors import CharacterError

_FINGERS = (("index", "Index"), ("middle", "Middle"), ("ring", "Ring"), ("pinky", "Little"))
_SIDES = (("left", "left"), ("right", "right"))

# VRM humanoid bone -> SMPL-X joint (spine segments are assigned by `assign_spine`)
VRM_BONES: dict[str, str] = {
    "hips": "pelvis", "neck": "neck", "head": "head", "jaw": "jaw",
    "leftEye": "left_eye_smplhf", "rightEye": "right_eye_smplhf",
}
for _s, _v in _SIDES:
    VRM_BONES.update({
        f"{_v}UpperLeg": f"{_s}_hip", f"{_v}LowerLeg": f"{_s}_knee", f"{_v}Foot": f"{_s}_ankle",
        f"{_v}Toes": f"{_s}_foot", f"{_v}Shoulder": f"{_s}_collar", f"{_v}UpperArm": f"{_s}_shoulder",
        f"{_v}LowerArm": f"{_s}_elbow", f"{_v}Hand": f"{_s}_wrist",
    })
    for _f, _F in _FINGERS:
        for _k, _seg in enumerate(("Proximal", "Intermediate", "Distal"), 1):
            VRM_BONES[f"{_v}{_F}{_seg}"] = f"{_s}_{_f}{_k}"
VRM0_THUMB = ("Proximal", "Intermediate", "Distal")      # VRM 0.x names the three thumb bones so
VRM1_THUMB = ("Metacarpal", "Proximal", "Distal")        # VRM 1.0 names them so
VRM_SPINE = ("spine", "chest", "upperChest")

# Mixamo (and BEAT v1 BVH) names; "mixamorig:" prefixes are stripped before matching
MIXAMO: dict[str, str] = {
    "pelvis": "Hips", "spine1": "Spine", "spine2": "Spine1", "spine3": "Spine2", "neck": "Neck",
    "head": "Head", "jaw": "Jaw", "left_eye_smplhf": "LeftEye", "right_eye_smplhf": "RightEye",
}
for _s, _v in (("left", "Left"), ("right", "Right")):
    MIXAMO.update({
        f"{_s}_hip": f"{_v}UpLeg", f"{_s}_knee": f"{_v}Leg", f"{_s}_ankle": f"{_v}Foot",
        f"{_s}_foot": f"{_v}ToeBase", f"{_s}_collar": f"{_v}Shoulder", f"{_s}_shoulder": f"{_v}Arm",
        f"{_s}_elbow": f"{_v}ForeArm", f"{_s}_wrist": f"{_v}Hand",
    })
    for _f in ("index", "middle", "ring", "pinky", "thumb"):
        for _k in (1, 2, 3):
            MIXAMO[f"{_s}_{_f}{_k}"] = f"{_v}Hand{_f.capitalize()}{_k}"

SMPLX: dict[str, str] = {n: n for n in JOINT_NAMES}
PRESETS: dict[str, dict[str, str]] = {"mixamo": MIXAMO, "smplx": SMPLX}

# bones a humanoid must have to be retargeted (SMPL-X names)
REQUIRED: tuple[str, ...] = (
    "pelvis", "neck", "head", "left_hip", "left_knee", "left_ankle", "right_hip", "right_knee", "right_ankle",
    "left_shoulder", "left_elbow", "left_wrist", "right_shoulder", "right_elbow", "right_wrist",
)


def strip_prefix(name: str) -> str:
    """'mixamorig:LeftArm' / 'mixamorig1:LeftArm' / 'Armature|LeftArm' -> 'LeftArm'."""
    for sep in (":", "|"):
        if sep in name:
            name = name.rsplit(sep, 1)[1]
    return name


def assign_spine(bones: list[str]) -> dict[str, str]:
    """Rig spine bones, hips to neck order -> SMPL-X spine joints: 1 -> spine3; 2 -> spine1, spine3;
    3 or more -> spine1, spine2, spine3 for the first, middle and last."""
    n = len(bones)
    if n == 0:
        return {}
    if n == 1:
        return {"spine3": bones[0]}
    if n == 2:
        return {"spine1": bones[0], "spine3": bones[1]}
    return {"spine1": bones[0], "spine2": bones[n // 2], "spine3": bones[-1]}


def vrm_map(human: dict[str, str], thumb: tuple[str, ...]) -> dict[str, str]:
    """VRM humanoid {vrm bone: node name} -> {SMPL-X joint: node name}."""
    out = {VRM_BONES[b]: node for b, node in human.items() if b in VRM_BONES}
    for s in ("left", "right"):
        for k, seg in enumerate(thumb, 1):
            if f"{s}Thumb{seg}" in human:
                out[f"{s}_thumb{k}"] = human[f"{s}Thumb{seg}"]
    out.update(assign_spine([human[b] for b in VRM_SPINE if b in human]))
    return out


def preset_map(preset: str, node_names: list[str]) -> dict[str, str]:
    """The preset's bones present in the rig (names compared without 'mixamorig:'-style prefixes). Mixamo rigs
    with a 4-segment spine (Spine..Spine3, as BEAT v1) get their spine through `assign_spine`."""
    if preset not in PRESETS:
        raise CharacterError(f"unknown bone-name preset {preset!r}: use one of {', '.join(PRESETS)} or a JSON map")
    by_short = {}
    for n in node_names:
        by_short.setdefault(strip_prefix(n), n)
    table = PRESETS[preset]
    out = {j: by_short[b] for j, b in table.items() if b in by_short and not j.startswith("spine")}
    if preset == "mixamo":
        spine = [by_short[b] for b in ("Spine", "Spine1", "Spine2", "Spine3") if b in by_short]
        out.update(assign_spine(spine))
    else:
        out.update({j: by_short[j] for j in ("spine1", "spine2", "spine3") if j in by_short})
    return out


def load_json_map(path: str | Path) -> dict[str, str]:
    """A JSON object {SMPL-X joint name: rig bone name}, e.g. {"pelvis": "root_hips", "left_wrist": "hand.L"}."""
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, RecursionError) as exc:
        raise CharacterError(f"bone map {path}: not a readable JSON file ({exc})") from None
    if not isinstance(data, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in data.items()):
        raise CharacterError(f"bone map {path}: expected a JSON object {{SMPL-X joint: bone name}}")
    unknown = sorted(set(data) - set(JOINT_NAMES))
    if unknown:
        raise CharacterError(f"bone map {path}: not SMPL-X joint names: {', '.join(unknown[:5])}")
    return dict(data)


def guess_map(node_names: list[str]) -> dict[str, str]:
    """The preset that names the most bones of this rig (Mixamo or SMPL-X)."""
    best = max((preset_map(p, node_names) for p in PRESETS), key=len)
    return best
