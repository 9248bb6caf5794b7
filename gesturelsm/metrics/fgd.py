"""FGD: the Frechet distance between feature sets of real and generated motion, with pluggable extractors.

An extractor turns one motion into feature rows (N, D): `extractor(motion, joints) -> np.ndarray`, where
`motion` is a MotionSequence and `joints` its (T, 55, 3) joint positions in metres (or None). Shipped:
- `KineticExtractor` / `GeometricExtractor`: training-free joint features (FGD_k / FGD_g, see
  motion_features.py), usable on small test sets; they are what `gesturelsm eval` reports by default.
- `EmageExtractor`: EMAGE's skeleton-conv encoder on 6D rotations, with its published weights
  (`AESKConv_240_100.bin`): the paper's FGD (the paper's table shows it x 1e-1).
"""
from __future__ import annotations

from pathlib import Path
from typing import Protocol, Sequence

import numpy as np

from .emage_fgd import SkeletonConvEncoder, emage_features, load_emage_weights
from .frechet import frechet_distance
from .motion_features import geometric_features, kinetic_features


class FeatureExtractor(Protocol):
    name: str

    def __call__(self, motion, joints: np.ndarray | None) -> np.ndarray: ...


class KineticExtractor:
    name = "fgd_k"

    def __call__(self, motion, joints: np.ndarray | None) -> np.ndarray:
        return kinetic_features(joints)


class GeometricExtractor:
    name = "fgd_g"

    def __call__(self, motion, joints: np.ndarray | None) -> np.ndarray:
        return geometric_features(joints)


class EmageExtractor:
    name = "fgd_emage"

    def __init__(self, weights: str | Path | dict | None = None, model=None):
        self.model = model if model is not None else SkeletonConvEncoder()
        if weights is not None:
            load_emage_weights(self.model, weights)
        self.model.eval()

    def __call__(self, motion, joints: np.ndarray | None) -> np.ndarray:
        return emage_features(self.model, motion.to_features()[:, :330])


def fgd(real: Sequence[np.ndarray] | np.ndarray, generated: Sequence[np.ndarray] | np.ndarray,
        normalize: bool = True) -> float:
    """Frechet distance between the pooled feature rows of real and generated motions.

    normalize: z-score both sets with the real set's per-dimension mean and std first (as FID_k / FID_g do),
    so that every feature counts alike whatever its unit; the score is then in units of the real data's
    spread. EMAGE's FGD does not normalise its latents: `EmageExtractor` rows are compared as they are."""
    r = np.concatenate(list(real)) if not isinstance(real, np.ndarray) else real
    g = np.concatenate(list(generated)) if not isinstance(generated, np.ndarray) else generated
    if normalize:
        mu, sd = r.mean(0), r.std(0)
        sd = np.where(sd > 1e-8 * max(float(sd.max()), 1e-12), sd, 1.0)
        r, g = (r - mu) / sd, (g - mu) / sd
    return frechet_distance(r, g)


def default_extractors(emage_weights: str | Path | None = None) -> list:
    ex: list = [KineticExtractor(), GeometricExtractor()]
    if emage_weights:
        ex.append(EmageExtractor(emage_weights))
    return ex
