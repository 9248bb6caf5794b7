"""A VRM character's face from the generated motion: the mouth opens (`aa`; VRM 0.x `a`) as SMPL-X's jaw does.

The jaw joint's opening is its rotation about the head's left-right axis (x in SMPL-X); 0.35 rad (about
20 degrees, a wide-open mouth in BEAT2) maps to weight 1. Only the characters that define the preset get it;
the FLAME expression coefficients have no agreed meaning in VRM's presets, so no other preset is driven.
"""
from __future__ import annotations

import numpy as np

from ..motion.skeleton import JOINT_INDEX

WIDE_OPEN = 0.35                                       # radians of jaw rotation = weight 1


def jaw_open(poses: np.ndarray) -> np.ndarray:
    """(T, 165) axis-angle poses -> (T,) mouth opening weight in [0, 1]."""
    j = JOINT_INDEX["jaw"]
    x = np.asarray(poses, np.float64).reshape(len(poses), -1, 3)[:, j, 0]
    return np.clip(x / WIDE_OPEN, 0.0, 1.0)


def morph_binds(gltf: dict, preset: str = "aa") -> list[tuple[int, int, float]]:
    """The (mesh index, morph target index, weight 0..1) a VRM preset expression sets, [] when it has none."""
    ext = gltf.get("extensions") or {}
    out: list[tuple[int, int, float]] = []
    try:
        if "VRMC_vrm" in ext:
            expr = ((ext["VRMC_vrm"].get("expressions") or {}).get("preset") or {}).get(preset) or {}
            for b in expr.get("morphTargetBinds", []):
                mesh = gltf["nodes"][int(b["node"])].get("mesh")
                if mesh is not None:
                    out.append((int(mesh), int(b["index"]), float(b.get("weight", 1.0))))
        elif "VRM" in ext:
            name0 = {"aa": "a", "ih": "i", "ou": "u", "ee": "e", "oh": "o"}.get(preset, preset)
            for g in (ext["VRM"].get("blendShapeMaster") or {}).get("blendShapeGroups", []):
                if str(g.get("presetName", "")).lower() == name0:
                    out += [(int(b["mesh"]), int(b["index"]), float(b.get("weight", 100.0)) / 100.0)
                            for b in g.get("binds", [])]
    except (KeyError, TypeError, ValueError, IndexError):
        return []
    return out
