"""The built-in mannequin: a deterministic, licence-free body in SMPL-X's npz layout.

`build_mannequin()` returns the arrays `smplx.SMPLX` reads (v_template, f, J_regressor, weights,
kintree_table, shapedirs, posedirs, hands_*, lmk_*), plus:
    vertex_id_names / vertex_id_values  the mannequin's own vertices for smplx's extra joints (nose, eyes,
                                        ears, toes, heels, finger tips), same keys as
                                        `smplx.vertex_ids.vertex_ids['smplx']`
    part_names / part_index             which body part each vertex belongs to
    model                               "gesturelsm-mannequin"
Rest pose, joint layout and units: see `mannequin_skeleton.py`. Skeleton proportions: `proportions.py`.

Blend shapes (shapedirs, metres per unit coefficient):
    beta 0   height: +4 % scale about the point between the soles (feet stay on the floor)
    beta 1   girth: +8 % cross-section scale of torso, neck, arms and legs about their axes
    expression 0 / 1 / 2   mouth open / smile / brows raised (see `mannequin_head.expression_fields`)
All other directions are zero; posedirs are zero (no pose correctives).
J_regressor: each row is an affine combination (weights sum to 1) of one ring (or band) of surface vertices around
the joint, solved so that it reproduces the designed joint exactly.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..constants import ASSETS
from ..motion.skeleton import JOINT_NAMES, NUM_JOINTS, PARENTS
from .mannequin_head import NOSE_TIP, expression_fields, eyeball, head, landmark_targets
from .mannequin_mesh import Part
from .mannequin_parts import both_sides, trunk
from .mannequin_skeleton import RestSkeleton, build_rest_skeleton
from .proportions import FINGERS

NUM_SHAPE, NUM_EXPR = 300, 100
HEIGHT_PER_BETA, GIRTH_PER_BETA = 0.04, 0.08
DEFAULT_PATH = ASSETS / "body" / "SMPLX_MANNEQUIN.npz"
MODEL_TAG = "gesturelsm-mannequin"

# joint -> (part, ring) whose vertices regress it
_REGRESSOR_RINGS: dict[str, tuple[str, str]] = {
    "pelvis": ("trunk", "pelvis"), "spine1": ("trunk", "spine1"), "spine2": ("trunk", "spine2"),
    "spine3": ("trunk", "spine3"), "neck": ("trunk", "neck"), "head": ("trunk", "head"),
    "jaw": ("head", "jaw_band"), "left_eye_smplhf": ("left_eye", "all"), "right_eye_smplhf": ("right_eye", "all"),
}
for _s in ("left", "right"):
    for _j in ("hip", "knee", "ankle"):
        _REGRESSOR_RINGS[f"{_s}_{_j}"] = ("trunk", f"{_s}_{_j}")
    _REGRESSOR_RINGS[f"{_s}_foot"] = (f"{_s}_foot", f"{_s}_foot")
    for _j in ("collar", "shoulder", "elbow", "wrist"):
        _REGRESSOR_RINGS[f"{_s}_{_j}"] = (f"{_s}_arm", f"{_s}_{_j}")
    for _f in FINGERS + ("thumb",):
        for _k in (1, 2, 3):
            _REGRESSOR_RINGS[f"{_s}_{_f}{_k}"] = (f"{_s}_{_f}", f"{_s}_{_f}{_k}")


def build_parts(sk: RestSkeleton) -> list[Part]:
    return [trunk(sk), head(sk), eyeball(sk, "left"), eyeball(sk, "right")] + both_sides(sk)


def affine_weights(points: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Weights w (K,) closest to uniform with sum(w) = 1 and w @ points = target (exact if reachable)."""
    K = len(points)
    A = np.concatenate([(points - target).T, np.ones((1, K))])  # (4, K), centred for conditioning
    b = np.array([0.0, 0.0, 0.0, 1.0])
    w0 = np.full(K, 1.0 / K)
    w = w0 + np.linalg.pinv(A) @ (b - A @ w0)
    err = np.abs(A @ w - b).max()
    if err > 1e-8:
        raise ValueError(f"joint at {target} is not an affine combination of its ring (error {err:.2e})")
    return w


def _closest_face(vertices: np.ndarray, faces: np.ndarray, point: np.ndarray) -> tuple[int, np.ndarray]:
    """The face nearest `point` (by centroid) and the clipped barycentric coordinates of its projection."""
    cent = vertices[faces].mean(1)
    fi = int(np.argmin(np.linalg.norm(cent - point, axis=1)))
    a, b, c = vertices[faces[fi]]
    v0, v1, v2 = b - a, c - a, point - a
    d00, d01, d11, d20, d21 = v0 @ v0, v0 @ v1, v1 @ v1, v2 @ v0, v2 @ v1
    den = d00 * d11 - d01 * d01
    l1 = (d11 * d20 - d01 * d21) / den
    l2 = (d00 * d21 - d01 * d20) / den
    bary = np.clip(np.array([1 - l1 - l2, l1, l2]), 0.0, None)
    return fi, bary / bary.sum()


def build_mannequin() -> dict[str, np.ndarray]:
    """All arrays of the mannequin model file (deterministic)."""
    sk = build_rest_skeleton()
    parts = build_parts(sk)
    offsets = np.cumsum([0] + [len(p.vertices) for p in parts])
    start = {p.name: int(o) for p, o in zip(parts, offsets)}
    part_of = {p.name: p for p in parts}
    V = int(offsets[-1])
    verts = np.concatenate([p.vertices for p in parts])
    faces = np.concatenate([p.faces + o for p, o in zip(parts, offsets)])
    weights = np.concatenate([p.weights for p in parts])
    axis = np.concatenate([p.axis_points for p in parts])
    girth = np.concatenate([np.full(len(p.vertices), float(p.girth)) for p in parts])
    part_index = np.concatenate([np.full(len(p.vertices), i) for i, p in enumerate(parts)])

    shapedirs = np.zeros((V, 3, NUM_SHAPE + NUM_EXPR))
    shapedirs[:, :, 0] = HEIGHT_PER_BETA * (verts - np.array([0.0, sk.sole_y, 0.0]))
    shapedirs[:, :, 1] = GIRTH_PER_BETA * (verts - axis) * girth[:, None]
    hs = start["head"]
    head_rel = part_of["head"].vertices - sk.joints[JOINT_NAMES.index("head")]
    shapedirs[hs:hs + len(head_rel), :, NUM_SHAPE:NUM_SHAPE + 3] = expression_fields(head_rel)

    J_reg = np.zeros((NUM_JOINTS, V))
    moved_by_expr = np.abs(shapedirs[:, :, NUM_SHAPE:]).sum((1, 2)) > 0
    for j, name in enumerate(JOINT_NAMES):
        part, ring = _REGRESSOR_RINGS[name]
        ids = part_of[part].rings[ring] + start[part]
        ids = ids[~moved_by_expr[ids]]
        J_reg[j, ids] = affine_weights(verts[ids], sk.joints[j])

    head_faces = faces[(faces >= hs).all(1) & (faces < hs + len(head_rel)).all(1)]
    lmk_idx, lmk_bary = [], []
    for pt in landmark_targets() + sk.joints[JOINT_NAMES.index("head")]:
        fi, bary = _closest_face(verts, head_faces, pt)
        lmk_idx.append(int(np.nonzero((faces == head_faces[fi]).all(1))[0][0]))
        lmk_bary.append(bary)

    ids = _vertex_ids(sk, parts, start)
    kintree = np.stack([np.array(PARENTS), np.arange(NUM_JOINTS)]).astype(np.int64)
    f32 = np.float32
    return {
        "v_template": verts.astype(f32), "f": faces.astype(np.int32), "J_regressor": J_reg.astype(f32),
        "weights": weights.astype(f32), "kintree_table": kintree, "shapedirs": shapedirs.astype(f32),
        "posedirs": np.zeros((V, 3, (NUM_JOINTS - 1) * 9), f32),
        "hands_componentsl": np.eye(45, dtype=f32), "hands_componentsr": np.eye(45, dtype=f32),
        "hands_meanl": np.zeros(45, f32), "hands_meanr": np.zeros(45, f32),
        "lmk_faces_idx": np.array(lmk_idx, np.int64), "lmk_bary_coords": np.array(lmk_bary, f32),
        "vertex_id_names": np.array(list(ids.keys())), "vertex_id_values": np.array(list(ids.values()), np.int64),
        "part_names": np.array([p.name for p in parts]), "part_index": part_index.astype(np.int16),
        "joint_positions": sk.joints.astype(f32), "model": np.array(MODEL_TAG),
    }


def _vertex_ids(sk: RestSkeleton, parts: list[Part], start: dict[str, int]) -> dict[str, int]:
    """Mannequin vertices for smplx's extra joints (keys of smplx.vertex_ids.vertex_ids['smplx'])."""
    by = {p.name: p for p in parts}
    H = sk.joints[JOINT_NAMES.index("head")]

    def nearest(part: str, point: np.ndarray) -> int:
        v = by[part].vertices
        return start[part] + int(np.argmin(np.linalg.norm(v - point, axis=1)))

    ids = {"nose": nearest("head", H + np.array(NOSE_TIP) + [0, 0, 0.02])}
    for s, c in (("l", "left"), ("r", "right")):
        eye = by[f"{c}_eye"].vertices
        ids[f"{s}eye"] = start[f"{c}_eye"] + int(np.argmax(eye[:, 2]))
        sx = 1.0 if c == "left" else -1.0
        ids[f"{s}ear"] = nearest("head", H + np.array([sx * 0.12, 0.072, -0.004]))
        for f in ("thumb",) + FINGERS:
            ids[f"{s}{f}"] = start[f"{c}_{f}"] + int(by[f"{c}_{f}"].rings["end_pole"][0])
    for s, c in (("L", "left"), ("R", "right")):
        foot = by[f"{c}_foot"].vertices
        sx = 1.0 if c == "left" else -1.0
        tip, sole = sk.toe_tips[c], sk.sole_y
        ids[f"{s}BigToe"] = nearest(f"{c}_foot", np.array([tip[0] - sx * 0.025, sole + 0.01, tip[2]]))
        ids[f"{s}SmallToe"] = nearest(f"{c}_foot", np.array([tip[0] + sx * 0.04, sole + 0.01, tip[2] - 0.05]))
        ids[f"{s}Heel"] = nearest(f"{c}_foot", np.array([tip[0], sole, foot[:, 2].min()]))
    return ids


def write_mannequin(path: str | Path = DEFAULT_PATH) -> Path:
    """Build the mannequin and write it as a compressed SMPL-X-style npz."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **build_mannequin())
    return path
