"""Fixtures for body tests: the shipped mannequin, a synthetic SMPL-X-like model, the shared data folder."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gesturelsm.motion.skeleton import NUM_JOINTS, PARENTS
from _support import SHARED

BVH = SHARED / "data" / "beat_v1" / "2_scott_0_1_1.bvh"
TAKE = SHARED / "data" / "beat2" / "smplxflame_30" / "2_scott_0_1_1.npz"
SMPLX_V, SMPLX_F = 10475, 20908


def synthetic_smplx_arrays(seed: int = 0) -> dict[str, np.ndarray]:
    """Random-ish but valid arrays with the real SMPL-X file's keys and shapes (10,475 vertices, no
    vertex-id keys, non-zero hand means, pose correctives, 300 + 100 shape/expression directions)."""
    rng = np.random.default_rng(seed)
    V, F = SMPLX_V, SMPLX_F
    v = rng.normal(size=(V, 3)) * np.array([0.2, 0.5, 0.1]) + np.array([0.0, -0.3, 0.0])
    J_reg = np.zeros((NUM_JOINTS, V))
    for j in range(NUM_JOINTS):  # each joint: a positive average of 20 vertices
        ids = rng.choice(V, 20, replace=False)
        w = rng.uniform(0.5, 1.0, 20)
        J_reg[j, ids] = w / w.sum()
    W = np.zeros((V, NUM_JOINTS))
    for k in range(4):
        W[np.arange(V), rng.integers(0, NUM_JOINTS, V)] += rng.uniform(0.1, 1.0, V)
    W /= W.sum(1, keepdims=True)
    Q = np.linalg.qr(rng.normal(size=(45, 45)))[0]
    bary = rng.uniform(0.1, 1.0, (51, 3))
    f32 = np.float32
    return {
        "v_template": v.astype(f32), "f": rng.integers(0, V, (F, 3)).astype(np.int32),
        "J_regressor": J_reg.astype(f32), "weights": W.astype(f32),
        "kintree_table": np.stack([np.array(PARENTS) % (2**32), np.arange(NUM_JOINTS)]).astype(np.int64),
        "shapedirs": (rng.normal(size=(V, 3, 400)) * 0.002).astype(f32),
        "posedirs": (rng.normal(size=(V, 3, 486)) * 0.001).astype(f32),
        "hands_componentsl": Q.astype(f32), "hands_componentsr": Q.T.copy().astype(f32),
        "hands_meanl": (rng.normal(size=45) * 0.3).astype(f32), "hands_meanr": (rng.normal(size=45) * 0.3).astype(f32),
        "lmk_faces_idx": rng.integers(0, F, 51).astype(np.int64),
        "lmk_bary_coords": (bary / bary.sum(1, keepdims=True)).astype(f32),
    }


@pytest.fixture(scope="session")
def synthetic_smplx_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding a synthetic SMPLX_NEUTRAL_2020.npz (stands in for the licensed file)."""
    d = tmp_path_factory.mktemp("smplx")
    np.savez(d / "SMPLX_NEUTRAL_2020.npz", **synthetic_smplx_arrays())
    return d


@pytest.fixture(scope="session")
def mannequin():
    from gesturelsm.body import load_body_model

    return load_body_model()


@pytest.fixture(scope="session")
def mannequin_arrays() -> dict[str, np.ndarray]:
    from gesturelsm.body.mannequin import DEFAULT_PATH

    with np.load(DEFAULT_PATH) as d:
        return {k: d[k] for k in d.files}


@pytest.fixture(scope="session")
def bvh_path() -> Path:
    if not BVH.exists():
        pytest.skip(f"BEAT v1 BVH not found at {BVH} (../shared beside the repo)")
    return BVH


@pytest.fixture(scope="session")
def take_path() -> Path:
    if not TAKE.exists():
        pytest.skip(f"real BEAT2 take not found at {TAKE} (../shared beside the repo)")
    return TAKE
