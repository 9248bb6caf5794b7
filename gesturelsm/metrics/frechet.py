"""Frechet distance between two sets of feature vectors (FID / FGD).

    FD = |mu_a - mu_b|^2 + tr(S_a + S_b - 2 (S_a S_b)^(1/2))

The matrix square root term is computed as tr((S_a^(1/2) S_b S_a^(1/2))^(1/2)): that matrix is symmetric
positive semi-definite, so its eigenvalues are real and >= 0 and the result is exact (FD(x, x) = 0 to float
precision) even when the covariances are singular, which they are for small test sets (fewer samples than
feature dimensions).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError


@dataclass(frozen=True)
class GaussianStats:
    mean: np.ndarray            # (D,)
    cov: np.ndarray             # (D, D)
    count: int                  # number of feature vectors


def gaussian_stats(features: np.ndarray) -> GaussianStats:
    """(N, D) feature vectors -> mean and maximum-likelihood (1/N) covariance. With 1/N, a set and the same
    set repeated (e.g. identical motions from several seeds) are the same Gaussian, at distance 0."""
    f = np.asarray(features, np.float64)
    if f.ndim != 2 or len(f) < 2:
        raise InputError(f"need at least 2 feature vectors of shape (N, D); got {f.shape}")
    return GaussianStats(f.mean(0), np.cov(f, rowvar=False, bias=True).reshape(f.shape[1], f.shape[1]), len(f))


def _psd_sqrt(m: np.ndarray) -> np.ndarray:
    w, v = np.linalg.eigh((m + m.T) / 2)
    return (v * np.sqrt(np.clip(w, 0, None))) @ v.T


def frechet_distance(a: GaussianStats | np.ndarray, b: GaussianStats | np.ndarray) -> float:
    """Frechet distance between two Gaussians fitted to feature sets (arrays (N, D) or GaussianStats)."""
    a = a if isinstance(a, GaussianStats) else gaussian_stats(a)
    b = b if isinstance(b, GaussianStats) else gaussian_stats(b)
    if a.mean.shape != b.mean.shape:
        raise ValueError(f"feature sizes differ: {a.mean.shape[0]} vs {b.mean.shape[0]}")
    sa = _psd_sqrt(a.cov)
    cross = np.sqrt(np.clip(np.linalg.eigvalsh(sa @ b.cov @ sa), 0, None)).sum()
    fd = float(((a.mean - b.mean) ** 2).sum() + np.trace(a.cov) + np.trace(b.cov) - 2 * cross)
    return max(fd, 0.0)
