"""A VRM character's face from the generated motion: the mouth visemes `aa`, `ih`, `ou`, `ee`, `oh` (VRM 0.x
`a`, `i`, `u`, `e`, `o`) and `blink`, measured on the SMPL-X body's own face.

The generated jaw pose and expression coefficients are put on the body's head (every other joint at rest) and
its 51 facial landmarks (FLAME's static ones, iBUG 17-67, which SMPL-X files and the mannequin carry) are read
per frame, relative to the neutral face (jaw closed, expression 0):
* opening o = (inner-lip gap - neutral gap) / (the gap at 0.35 rad of jaw rotation, a wide-open mouth in BEAT2,
  - neutral gap), clipped to [0, 1];
* spread s = (mouth-corner distance - the distance the same jaw pose gives without expressions) / (10 % of the
  neutral distance), clipped to [-1, 1]: +1 a mouth pulled wide, -1 a rounded, narrowed one; the jaw alone sets
  the opening, the lips (expressions) the width.
The rule: the total weight is o, shared by the mouth's width class (wide s+, round s-, neutral 1 - |s|) times
its height class (high o, low 1 - o):
    aa = o (1 - |s|) o      ee = o s+ o      oh = o s- o      ih = o (s+ + 1 - |s|) (1 - o)      ou = o s- (1 - o)
so a closed mouth gives 0 everywhere, every weight is in [0, 1], they sum to o, and a wider-open jaw raises
`aa`. `blink` = the eyelid closure (1 - eye-landmark gap / neutral gap), with closures under 15 % read as open
(0) and full closure as 1. The built-in mannequin's expression basis has no eyelid motion (its three
expressions open the mouth, smile and raise the brows), so on it `blink` stays 0; an SMPL-X model file with
FLAME's expression basis closes the eyelids and drives it.
"""
from __future__ import annotations

import numpy as np

from ..motion.skeleton import JOINT_INDEX

WIDE_OPEN = 0.35                                       # radians of jaw rotation = fully open
FULL_SPREAD = 0.10                                     # mouth width change (fraction of neutral) = s of +-1
BLINK_FROM = 0.15                                      # eyelid closures below this are not blinks
VISEMES = ("aa", "ih", "ou", "ee", "oh")
PRESETS = VISEMES + ("blink",)
VRM0_NAMES = {"aa": "a", "ih": "i", "ou": "u", "ee": "e", "oh": "o", "blink": "blink"}
# indices into the 51 static landmarks (iBUG 17-67): inner lips 60-67, outer mouth corners 48 / 54, eyelids
INNER_UPPER, INNER_LOWER = [44, 45, 46], [50, 49, 48]
CORNERS = (31, 37)
LID_UPPER, LID_LOWER = [20, 21, 26, 27], [24, 23, 30, 29]


def jaw_open(poses: np.ndarray) -> np.ndarray:
    """(T, 165) axis-angle poses -> (T,) the jaw's opening in [0, 1] (its rotation about x / WIDE_OPEN)."""
    j = JOINT_INDEX["jaw"]
    x = np.asarray(poses, np.float64).reshape(len(poses), -1, 3)[:, j, 0]
    return np.clip(x / WIDE_OPEN, 0.0, 1.0)


def face_landmarks(body, jaw: np.ndarray, expressions: np.ndarray | None, betas=None, chunk: int = 512) -> np.ndarray:
    """(T, 51, 3) the body's facial landmarks with only the jaw (T, 3 axis-angle) and expressions posed."""
    jaw = np.asarray(jaw, np.float64).reshape(-1, 3)
    T = len(jaw)
    tri = np.asarray(body.faces, np.int64)[body.module.lmk_faces_idx.cpu().numpy().astype(np.int64)]   # (51, 3)
    bary = body.module.lmk_bary_coords.cpu().numpy().astype(np.float64)
    used, inverse = np.unique(tri, return_inverse=True)
    inverse = inverse.reshape(tri.shape)
    out = np.empty((T, len(bary), 3))
    for s in range(0, T, chunk):
        e = min(T, s + chunk)
        poses = np.zeros((e - s, 165))
        poses[:, 3 * JOINT_INDEX["jaw"]:3 * JOINT_INDEX["jaw"] + 3] = jaw[s:e]
        ex = None if expressions is None else np.asarray(expressions)[s:e]
        v = body.forward_subset(used, poses, ex, betas).astype(np.float64)
        out[s:e] = np.einsum("tkcx,kc->tkx", v[:, inverse], bary)
    return out


def landmark_gap(lm: np.ndarray, a: list[int], b: list[int], axes: slice = slice(0, 3)) -> np.ndarray:
    """(...,) mean distance between landmarks a[i] and b[i] of (..., 51, 3) landmarks, over the coordinates `axes`."""
    return np.linalg.norm(lm[..., a, axes] - lm[..., b, axes], axis=-1).mean(-1)


def face_weights(body, poses: np.ndarray, expressions: np.ndarray | None = None, betas=None,
                 wide_open: float = WIDE_OPEN) -> dict[str, np.ndarray]:
    """{preset: (T,) weight in [0, 1]} for VISEMES and `blink` (module docstring). `body`: a BodyModel with
    facial landmarks (the mannequin or an SMPL-X file); poses (T, 165); `wide_open`: the jaw rotation (radians)
    that counts as a fully open mouth (export/alive.py's exports use a smaller one, a face capture's scale)."""
    poses = np.asarray(poses, np.float64).reshape(len(poses), -1)
    T = len(poses)
    j = 3 * JOINT_INDEX["jaw"]
    ref = face_landmarks(body, np.array([[0.0, 0, 0], [wide_open, 0, 0]]), None, betas)
    lm = face_landmarks(body, poses[:, j:j + 3], expressions, betas)
    jaw_only = lm if expressions is None else face_landmarks(body, poses[:, j:j + 3], None, betas)
    gap0, gap_wide = landmark_gap(ref, INNER_UPPER, INNER_LOWER)
    o = np.clip((landmark_gap(lm, INNER_UPPER, INNER_LOWER) - gap0) / max(gap_wide - gap0, 1e-9), 0.0, 1.0)
    width = lambda x: np.linalg.norm(x[..., CORNERS[0], :] - x[..., CORNERS[1], :], axis=-1)  # noqa: E731
    w0 = float(width(ref[0]))
    s = np.clip((width(lm) - width(jaw_only)) / (FULL_SPREAD * w0), -1.0, 1.0)
    wide, rnd, neutral = np.maximum(s, 0.0), np.maximum(-s, 0.0), 1.0 - np.abs(s)
    out = {"aa": o * neutral * o, "ee": o * wide * o, "oh": o * rnd * o,
           "ih": o * (wide + neutral) * (1 - o), "ou": o * rnd * (1 - o)}
    lid0 = float(landmark_gap(ref[0], LID_UPPER, LID_LOWER))
    closure = 1.0 - landmark_gap(lm, LID_UPPER, LID_LOWER) / max(lid0, 1e-9)
    out["blink"] = np.clip((closure - BLINK_FROM) / (1.0 - BLINK_FROM), 0.0, 1.0)
    return {k: np.clip(v, 0.0, 1.0).reshape(T) for k, v in out.items()}


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
            name0 = VRM0_NAMES.get(preset, preset)
            for g in (ext["VRM"].get("blendShapeMaster") or {}).get("blendShapeGroups", []):
                if str(g.get("presetName", "")).lower() == name0:
                    out += [(int(b["mesh"]), int(b["index"]), float(b.get("weight", 100.0)) / 100.0)
                            for b in g.get("binds", [])]
    except (KeyError, TypeError, ValueError, IndexError):
        return []
    return out


def driven_presets(gltf: dict) -> list[str]:
    """The PRESETS this character defines (each gets morph-weight animation; the others are left alone)."""
    return [p for p in PRESETS if morph_binds(gltf, p)]


def _targets(meshes: list, mesh: int) -> int:
    """How many morph targets glTF mesh `mesh` has (its first primitive's; every primitive has as many)."""
    return len((meshes[mesh].get("primitives") or [{}])[0].get("targets", []))


def morph_channels(gltf: dict) -> list[tuple[int, int]]:
    """The (mesh index, morph target index) pairs the character's driven presets bind, sorted: the channels a player
    animates (every other morph target keeps its default weight, which `morph_weights` also leaves there)."""
    meshes = gltf.get("meshes") or []
    return sorted({(mesh, k) for p in driven_presets(gltf) for mesh, k, _ in morph_binds(gltf, p)
                   if 0 <= mesh < len(meshes) and 0 <= k < _targets(meshes, mesh)})


def channel_weights(per_mesh: dict[int, np.ndarray], channels: list[tuple[int, int]], frames: int) -> np.ndarray:
    """(frames, len(channels)) float32: column j is `per_mesh[mesh][:, k]` (`morph_weights`) of channel j =
    (mesh, k)."""
    if not channels:
        return np.zeros((frames, 0), np.float32)
    return np.stack([per_mesh[m][:, k] for m, k in channels], axis=1).astype(np.float32)


def morph_weights(gltf: dict, weights: dict[str, np.ndarray]) -> dict[int, np.ndarray]:
    """{mesh index: (T, targets) morph weights} for the meshes the character's presets bind: each mesh's default
    weights plus, per preset, its bind weight times the preset's weight, clipped to [0, 1]."""
    out: dict[int, np.ndarray] = {}
    meshes = gltf.get("meshes") or []
    for preset, w in weights.items():
        w = np.asarray(w, np.float64)
        for mesh, k, bind in morph_binds(gltf, preset):
            if not 0 <= mesh < len(meshes):
                continue
            if mesh not in out:
                K = _targets(meshes, mesh)
                base = np.asarray((meshes[mesh].get("weights") or [0.0] * K)[:K], np.float64)
                out[mesh] = np.tile(np.pad(base, (0, K - len(base))), (len(w), 1))
            if k < out[mesh].shape[1]:
                out[mesh][:, k] += bind * w
    return {m: np.clip(W, 0.0, 1.0) for m, W in out.items()}
