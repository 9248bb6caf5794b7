"""SMPL-X model files: where to find one, and checking that smplx can use it (clear errors otherwise).

Resolution: an explicit path, else $GESTURELSM_SMPLX_MODEL, else the built-in mannequin
(`assets/body/SMPLX_MANNEQUIN.npz`). A directory is searched for SMPLX_NEUTRAL_2020.npz / SMPLX_NEUTRAL.npz,
also in a `smplx/` subfolder (EMAGE's layout). Keys smplx reads: v_template (V, 3), f (F, 3),
J_regressor (55, V), weights (V, 55), kintree_table (2, 55), shapedirs (V, 3, 400), posedirs (V, 3, 486),
hands_components{l,r} (45, 45), hands_mean{l,r} (45,), lmk_faces_idx (51,), lmk_bary_coords (51, 3).
"""
from __future__ import annotations

import os
import zipfile
from pathlib import Path

import numpy as np

from ..motion.skeleton import NUM_JOINTS
from ..errors import BodyModelError
from ..safe_load import UnsafePickleError, load_npz
from .mannequin import DEFAULT_PATH, write_mannequin

ENV_VAR = "GESTURELSM_SMPLX_MODEL"
SMPLX_FILE_NAMES = ("SMPLX_NEUTRAL_2020.npz", "SMPLX_NEUTRAL.npz")
HINT = "expected an SMPL-X model file such as SMPLX_NEUTRAL_2020.npz"
_MIN_VERTICES_DEFAULT_IDS = 9930   # smplx's default extra-joint vertex ids go up to 9929


def default_model_path() -> Path:
    """The shipped mannequin; rebuilt into a user cache if the asset is missing (e.g. a wheel install)."""
    if DEFAULT_PATH.exists():
        return DEFAULT_PATH
    cached = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "gesturelsm" / DEFAULT_PATH.name
    return cached if cached.exists() else write_mannequin(cached)


def resolve_model_path(path: str | Path | None = None) -> Path:
    """The model file to load: `path`, else $GESTURELSM_SMPLX_MODEL, else the built-in mannequin."""
    from_env = False
    if path is None or str(path) == "":
        from_env = bool(os.environ.get(ENV_VAR))
        path = os.environ.get(ENV_VAR) or default_model_path()
    p = Path(path).expanduser()
    where = f" (from ${ENV_VAR}; unset it to use the built-in mannequin)" if from_env else ""
    if p.is_dir():
        for cand in [p / n for n in SMPLX_FILE_NAMES] + [p / "smplx" / n for n in SMPLX_FILE_NAMES]:
            if cand.is_file():
                return cand
        raise BodyModelError(f"{p}{where} is a directory without {' or '.join(SMPLX_FILE_NAMES)} — {HINT}")
    if not p.exists():
        raise BodyModelError(f"{p}{where}: file not found — {HINT}")
    return p


def validate_model_file(path: Path) -> dict[str, int]:
    """Check the keys and shapes smplx needs; returns {'vertices', 'faces', 'shape_dims'}."""
    if not zipfile.is_zipfile(path):
        raise BodyModelError(f"{path} is not an .npz file — {HINT}")
    try:  # pickled members only through an allow-list: smplx itself then loads with pickles allowed
        data = load_npz(path)
    except UnsafePickleError as exc:
        raise BodyModelError(f"{exc}; refusing to load it (a pickle can run code) — {HINT}") from None
    except Exception as exc:
        raise BodyModelError(f"{path} is not a readable .npz file ({exc}) — {HINT}") from None
    need = ("v_template", "f", "J_regressor", "weights", "kintree_table", "shapedirs", "posedirs",
            "hands_componentsl", "hands_componentsr", "hands_meanl", "hands_meanr",
            "lmk_faces_idx", "lmk_bary_coords")
    for key in need:
        if key not in data:
            raise BodyModelError(f"{path} is missing '{key}' — {HINT}")
    a = {k: data[k] for k in need}
    has_ids = "vertex_id_names" in data and "vertex_id_values" in data
    V = a["v_template"].shape[0] if a["v_template"].ndim == 2 else -1
    F = a["f"].shape[0] if a["f"].ndim == 2 else -1
    expected = {
        "v_template": (V, 3), "f": (F, 3), "J_regressor": (NUM_JOINTS, V), "weights": (V, NUM_JOINTS),
        "kintree_table": (2, NUM_JOINTS), "posedirs": (V, 3, (NUM_JOINTS - 1) * 9),
        "hands_componentsl": (45, 45), "hands_componentsr": (45, 45), "hands_meanl": (45,), "hands_meanr": (45,),
    }
    for key, shape in expected.items():
        if a[key].shape != shape or V < 1:
            raise BodyModelError(f"{path}: '{key}' has shape {a[key].shape}, expected {shape} — {HINT}")
    sd = a["shapedirs"]
    if sd.ndim != 3 or sd.shape[:2] != (V, 3) or sd.shape[2] < 20:
        raise BodyModelError(f"{path}: 'shapedirs' has shape {sd.shape}, expected ({V}, 3, 400) — {HINT}")
    faces = a["f"]
    if faces.size and (faces.min() < 0 or faces.max() >= V):
        raise BodyModelError(f"{path}: 'f' indexes vertices outside 0..{V - 1}")
    lmk = a["lmk_faces_idx"]
    if a["lmk_bary_coords"].shape != (lmk.shape[0], 3) or (lmk.size and lmk.max() >= F):
        raise BodyModelError(f"{path}: 'lmk_faces_idx'/'lmk_bary_coords' do not match the {F} faces")
    if not has_ids and V < _MIN_VERTICES_DEFAULT_IDS:
        raise BodyModelError(f"{path} has {V} vertices and no 'vertex_id_names'/'vertex_id_values': smplx's "
                             f"default SMPL-X vertex ids need at least {_MIN_VERTICES_DEFAULT_IDS} — {HINT}")
    return {"vertices": V, "faces": F, "shape_dims": sd.shape[2]}


def used_dims(path: Path) -> tuple[int, int]:
    """Shape / expression directions up to the last non-zero one (at least 10 each): the rest are zero
    and only cost time (smplx concatenates and contracts all of them on every call)."""
    with np.load(path, allow_pickle=False) as data:
        sd = np.asarray(data["shapedirs"])
    nz = np.nonzero(np.abs(sd).reshape(-1, sd.shape[-1]).max(0) > 0)[0]
    n_shape = 300 if sd.shape[-1] >= 400 else 10
    last_b = max([k for k in nz if k < n_shape], default=-1) + 1
    last_e = max([k - n_shape for k in nz if k >= n_shape], default=-1) + 1
    return max(10, int(last_b)), max(10, int(last_e))
