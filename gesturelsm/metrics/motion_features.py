"""Training-free motion features for FGD, after FID_k / FID_g of the dance literature (Bailando, AIST++).

Both work on joint positions (T, 55, 3) in metres at 30 fps, with the root trajectory removed (positions
relative to the pelvis), cut into windows of `window` frames every `stride` frames; one feature vector per
window, so even one short held-out clip gives a usable set (a 12.7 s clip: 22 windows).

- kinetic (FGD_k): per joint of `FEATURE_JOINTS`, the window's mean squared horizontal speed, mean squared
  vertical speed (kinetic energies, m^2/s^2) and mean acceleration magnitude (m/s^2, "energy expenditure");
  17 joints x 3 = 51 numbers.
- geometric (FGD_g): distances between all pairs of pelvis, spine3, head, shoulders, elbows and wrists
  (36 pairs), averaged over the window, and their standard deviation within it; 72 numbers, metres.
  A continuous stand-in for the boolean geometric relations of FID_g.

These scores are comparable between methods evaluated against the same ground truth, not with the paper's
FGD (which needs EMAGE's trained autoencoder, see `emage_fgd.py`).
"""
from __future__ import annotations

from itertools import combinations

import numpy as np

# spine3, neck, head, collars, shoulders, elbows, wrists, knees, ankles, index/thumb finger tips (SMPL-X ids)
FEATURE_JOINTS: tuple[int, ...] = (9, 12, 15, 13, 14, 16, 17, 18, 19, 20, 21, 4, 5, 27, 39, 42, 54)
GEOMETRY_JOINTS: tuple[int, ...] = (9, 15, 16, 17, 18, 19, 20, 21)   # paired with each other and the pelvis
WINDOW, STRIDE = 32, 16


def root_relative(joints: np.ndarray) -> np.ndarray:
    """(T, 55, 3) -> positions relative to the pelvis (joint 0) of the same frame."""
    return joints - joints[:, :1]


def windows(x: np.ndarray, window: int = WINDOW, stride: int = STRIDE) -> np.ndarray:
    """(T, ...) -> (N, window, ...) windows; a sequence shorter than one window gives one (shorter) window."""
    T = len(x)
    if T <= window:
        return x[None]
    starts = range(0, T - window + 1, stride)
    return np.stack([x[s:s + window] for s in starts])


def kinetic_features(joints: np.ndarray, fps: int = 30, window: int = WINDOW, stride: int = STRIDE,
                     joint_ids: tuple[int, ...] = FEATURE_JOINTS) -> np.ndarray:
    """(T, 55, 3) metres -> (N windows, 3 * len(joint_ids))."""
    p = root_relative(np.asarray(joints, np.float64))[:, list(joint_ids)]      # (T, J, 3)
    w = windows(p, window, stride)                                               # (N, W, J, 3)
    v = np.diff(w, axis=1) * fps                                                 # (N, W-1, J, 3) m/s
    a = np.diff(v, axis=1) * fps                                                 # (N, W-2, J, 3) m/s^2
    horiz = (v[..., 0] ** 2 + v[..., 2] ** 2).mean(1)                            # (N, J)
    vert = (v[..., 1] ** 2).mean(1)
    acc = np.linalg.norm(a, axis=-1).mean(1)
    return np.concatenate([horiz, vert, acc], axis=1)


def geometric_features(joints: np.ndarray, window: int = WINDOW, stride: int = STRIDE,
                       joint_ids: tuple[int, ...] = GEOMETRY_JOINTS) -> np.ndarray:
    """(T, 55, 3) metres -> (N windows, 2 * pairs): mean and std of pairwise joint distances per window."""
    p = root_relative(np.asarray(joints, np.float64))
    pairs = list(combinations([0, *joint_ids], 2))
    d = np.stack([np.linalg.norm(p[:, i] - p[:, j], axis=-1) for i, j in pairs], axis=1)   # (T, P)
    w = windows(d, window, stride)                                               # (N, W, P)
    return np.concatenate([w.mean(1), w.std(1)], axis=1)
