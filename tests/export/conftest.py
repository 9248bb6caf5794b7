"""Fixtures for export tests: the mannequin and a short motion with large, varied rotations."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.motion import MotionSequence


@pytest.fixture(scope="session")
def wild_motion() -> MotionSequence:
    """12 frames: random rotations up to ~2.5 rad on every joint (incl. the root), translation drift, some
    joints exactly / nearly at the BVH Euler order's gimbal lock (middle angle x = +-90 deg), expressions."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(7)
    T = 12
    aa = rng.normal(size=(T, 55, 3))
    aa *= (rng.uniform(0.1, 2.5, size=(T, 55, 1)) / np.linalg.norm(aa, axis=-1, keepdims=True))
    for t, (j, x) in enumerate([(18, 90.0), (19, -90.0), (4, 89.999), (16, -89.99)]):
        aa[t, j] = Rotation.from_euler("ZXY", [30.0, x, -50.0], degrees=True).as_rotvec()
    trans = np.cumsum(rng.normal(scale=0.01, size=(T, 3)), 0) + [0.1, 1.3, -0.2]
    expr = np.zeros((T, 100))
    expr[:, :3] = rng.uniform(-1, 1, size=(T, 3))
    return MotionSequence(aa.reshape(T, 165), trans, expr)


@pytest.fixture(scope="session")
def hand_mean_body(tmp_path_factory):
    """The mannequin with a non-zero relaxed-hand mean, loaded with flat_hand_mean=False (as EMAGE's renderers
    load SMPL-X): exports must add the mean as the body model does."""
    from gesturelsm.body import load_body_model
    from gesturelsm.body.mannequin import DEFAULT_PATH

    with np.load(DEFAULT_PATH) as d:
        arrays = {k: d[k] for k in d.files}
    rng = np.random.default_rng(3)
    arrays["hands_meanl"] = (rng.normal(size=45) * 0.3).astype(np.float32)
    arrays["hands_meanr"] = (rng.normal(size=45) * 0.3).astype(np.float32)
    path = tmp_path_factory.mktemp("hands") / "SMPLX_HANDMEAN.npz"
    np.savez(path, **arrays)
    return load_body_model(path, flat_hand_mean=False)
