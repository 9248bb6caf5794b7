"""The GENEA Leaderboard's pose metrics on raw axis-angle poses, as GENEALeaderboard/objective_metric's
`exp_eval_metrics.py` defines them (used by `gesturelsm genea metrics` and `gesturelsm eval`; docs/GENEA.md):

- FD_g: Fréchet distance between Gaussians (mean, unbiased covariance) fitted to the poses (T, 165) of every frame
  of every generated sample pooled, and of every frame of the human motion;
- FD_k: the same on frame-to-frame differences (within each sequence);
- DIV_k: per sample, the variance over time of each of the 165 numbers; the mean over samples and numbers;
- DIV_sample: per speech, its samples trimmed to the shortest, the variance across samples of every number of every
  frame, averaged; then averaged over speeches.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from ..errors import InputError
from .frechet import GaussianStats, frechet_distance


def fit(rows: np.ndarray) -> GaussianStats:
    """Mean and unbiased covariance (numpy's np.cov, as the reference fits them)."""
    rows = np.asarray(rows, np.float64)
    if len(rows) < 2:
        raise InputError("too few frames to fit a Gaussian")
    return GaussianStats(rows.mean(0), np.atleast_2d(np.cov(rows, rowvar=False)), len(rows))


def _flat(p: np.ndarray) -> np.ndarray:
    p = np.asarray(p, np.float64)
    return p.reshape(len(p), -1)


def fd_g(human: Sequence[np.ndarray], generated: Sequence[np.ndarray]) -> float:
    return frechet_distance(fit(np.concatenate([_flat(h) for h in human])),
                            fit(np.concatenate([_flat(g) for g in generated])))


def fd_k(human: Sequence[np.ndarray], generated: Sequence[np.ndarray]) -> float:
    return frechet_distance(fit(np.concatenate([np.diff(_flat(h), axis=0) for h in human])),
                            fit(np.concatenate([np.diff(_flat(g), axis=0) for g in generated])))


def div_k(generated: Sequence[np.ndarray]) -> float:
    return float(np.mean([np.var(_flat(g), axis=0).mean() for g in generated]))


def div_sample(groups: Sequence[Sequence[np.ndarray]]) -> float | None:
    """`groups`: per speech, its samples; None when a speech has fewer than two (the reference gives none then)."""
    values = []
    for samples in groups:
        if len(samples) < 2:
            return None
        n = min(len(s) for s in samples)
        stack = np.stack([_flat(s)[:n] for s in samples]).reshape(len(samples), -1)
        values.append(float(np.var(stack, axis=0).mean()))
    return float(np.mean(values)) if values else None


__all__ = ["div_k", "div_sample", "fd_g", "fd_k", "fit"]
