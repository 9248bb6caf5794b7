"""Statistics for study results: Wilson intervals, the two-sided sign test, Holm's correction, Bradley-Terry
scores (Newton's method) with bootstrap intervals over raters, and bootstrap means.

Bradley-Terry: P(i beats j) = s_i / (s_i + s_j). Scores are log-strengths log(s_i / s_ref), so the reference
method scores 0 and a difference of 1 means odds of e : 1. Every pair gets `prior` pseudo-wins each way, which
keeps a method that never won finite and pulls estimates towards 0 by a negligible amount once a pair has tens
of comparisons.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import binomtest

Z95 = 1.959963984540054
ELO_SCALE = 400 / np.log(10)     # Elo points per unit of Bradley-Terry log-strength (200 points: preferred ~76 %)


def wilson(k: float, n: float, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a proportion k / n ((nan, nan) when n = 0)."""
    if n <= 0:
        return float("nan"), float("nan")
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return float(max(0.0, centre - half)), float(min(1.0, centre + half))


def sign_test(wins: int, losses: int) -> float:
    """Two-sided exact binomial (sign) test of wins vs losses against 50:50; ties are left out before."""
    n = wins + losses
    return 1.0 if n == 0 else float(binomtest(wins, n, 0.5, alternative="two-sided").pvalue)


def holm(p: list[float] | np.ndarray) -> np.ndarray:
    """Holm-Bonferroni adjusted p-values (family-wise error): reject where adjusted p < alpha."""
    p = np.asarray(p, np.float64)
    m = len(p)
    order = np.argsort(p)
    adj = np.empty(m)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, (m - rank) * p[i])
        adj[i] = min(1.0, running)
    return adj


def bradley_terry(wins: np.ndarray, reference: int = 0, prior: float = 0.1, tol: float = 1e-9,
                  max_iter: int = 100) -> np.ndarray:
    """Log-strength scores (reference = 0) from a win matrix wins[..., i, j] = times i beat j, batched over
    leading axes: Newton's method on the log-likelihood with the reference's score held at 0. The prior's
    pseudo-wins on every pair make the likelihood strictly concave, so each step is well defined."""
    w = np.asarray(wins, np.float64)
    m = w.shape[-1]
    w = w + prior * (1 - np.eye(m))
    n = w + np.swapaxes(w, -1, -2)
    won = w.sum(-1)                                                   # (..., M)
    free = np.array([i for i in range(m) if i != reference])
    theta = np.zeros(w.shape[:-1])
    for _ in range(max_iter):
        p = 1 / (1 + np.exp(theta[..., None, :] - theta[..., :, None]))     # p[i, j] = P(i beats j)
        grad = won - (n * p).sum(-1)
        c = n * p * (1 - p)
        hess = c - np.eye(m) * c.sum(-1)[..., None]                        # negative definite on `free`
        g, h = grad[..., free], hess[..., free[:, None], free[None, :]]
        step = np.linalg.solve(h, g[..., None])[..., 0]
        theta[..., free] -= step
        if np.max(np.abs(step), initial=0.0) < tol:
            break
    return theta


@dataclass
class Scores:
    """Bradley-Terry scores with 95% percentile-bootstrap intervals over raters."""
    score: np.ndarray
    low: np.ndarray
    high: np.ndarray
    boot: np.ndarray          # (B, M) bootstrap replicates


def bt_bootstrap(per_rater: np.ndarray, reference: int = 0, n_boot: int = 1000, seed: int = 0,
                 prior: float = 0.1, level: float = 0.95) -> Scores:
    """per_rater: (R, M, M) win matrices, one per rater. Raters are resampled with replacement (their answers
    are not independent of each other), the model refitted on each resample."""
    per_rater = np.asarray(per_rater, np.float64)
    r = per_rater.shape[0]
    score = bradley_terry(per_rater.sum(0), reference, prior)
    rng = np.random.default_rng(seed)
    counts = rng.multinomial(r, np.full(r, 1.0 / r), size=n_boot)         # (B, R)
    boot = bradley_terry(np.einsum("br,rij->bij", counts, per_rater), reference, prior)
    a = (1 - level) / 2
    return Scores(score, np.quantile(boot, a, axis=0), np.quantile(boot, 1 - a, axis=0), boot)


def elo(scores: np.ndarray) -> np.ndarray:
    """Elo ratings from Bradley-Terry log-strengths (..., M): 1000 + 400 / ln 10 x (score - mean score), so the
    mean method rates 1000 and a gap of 400 points is odds of 10 : 1 (GENEA's realism rating)."""
    s = np.asarray(scores, np.float64)
    return 1000 + ELO_SCALE * (s - s.mean(-1, keepdims=True))


def bootstrap_mean(per_rater: list[np.ndarray], n_boot: int = 1000, seed: int = 0,
                   level: float = 0.95) -> tuple[float, float, float]:
    """Mean of all values with a percentile-bootstrap interval that resamples raters (each item: one rater's
    values)."""
    groups = [np.asarray(g, np.float64) for g in per_rater if len(g)]
    if not groups:
        return float("nan"), float("nan"), float("nan")
    sums = np.array([g.sum() for g in groups])
    sizes = np.array([len(g) for g in groups])
    rng = np.random.default_rng(seed)
    counts = rng.multinomial(len(groups), np.full(len(groups), 1.0 / len(groups)), size=n_boot)
    means = (counts @ sums) / (counts @ sizes)
    a = (1 - level) / 2
    return float(sums.sum() / sizes.sum()), float(np.quantile(means, a)), float(np.quantile(means, 1 - a))


__all__ = ["Scores", "bootstrap_mean", "bradley_terry", "bt_bootstrap", "elo", "holm", "sign_test", "wilson"]
