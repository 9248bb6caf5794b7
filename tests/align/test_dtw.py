"""The DTW against a brute-force oracle, its path invariants, and the coarse-to-fine driver on a known warp."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.align.dtw import STEPS, _step_cells, dtw, multiscale_dtw


def _unit(x: np.ndarray) -> np.ndarray:
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def brute_force(C: np.ndarray, skip: float | None, gap: float | None) -> float:
    """Plain O(N M) recursion over every cell, written independently of the row-vectorised version."""
    n, m = C.shape
    D = np.full((n, m), np.inf)
    for i in range(n):
        for j in range(m):
            best = np.inf
            if i == 0:
                best = 2 * C[0, j] + (0 if j == 0 else (skip * j if skip is not None else np.inf))
            elif j == 0 and skip is not None:
                best = 2 * C[i, 0] + skip * i
            for di, dj in STEPS:
                if i >= di and j >= dj:
                    cells = _step_cells(di, dj)
                    step = sum(C[i + a, j + b] for a, b in cells) * (di + dj) / len(cells)
                    best = min(best, D[i - di, j - dj] + step)
            if gap is not None:
                if i >= 1:
                    best = min(best, D[i - 1, j] + gap)
                if j >= 1:
                    best = min(best, D[i, j - 1] + gap)
            D[i, j] = best
    ends = [D[n - 1, j] + (0 if j == m - 1 else (skip * (m - 1 - j) if skip is not None else np.inf))
            for j in range(m)]
    if skip is not None:
        ends += [D[i, m - 1] + skip * (n - 1 - i) for i in range(n)]
    return min(ends) / (n + m)


@pytest.mark.parametrize("skip, gap", [(None, None), (0.6, None), (0.6, 0.9)])
def test_cost_equals_the_brute_force_optimum(skip, gap):
    rng = np.random.default_rng(1)
    for _ in range(25):
        n, m = rng.integers(2, 13, size=2)
        A, B = _unit(rng.normal(size=(n, 4))), _unit(rng.normal(size=(m, 4)))
        C = np.maximum(1 - (A @ B.T).astype(np.float32), 0).astype(float)
        expected = brute_force(C, skip, gap)
        if not np.isfinite(expected):
            with pytest.raises(ValueError):
                dtw(A, B, None, skip, gap)
            continue
        path, cost = dtw(A, B, None, skip, gap)
        assert cost == pytest.approx(expected, rel=1e-5)
        steps = np.diff(path, axis=0)
        assert (steps >= 0).all() and (steps.sum(1) >= 1).all()        # monotonic, always moving
        assert (np.abs(steps) <= 1).all()                                # contiguous (long steps expanded)
        if skip is None:
            assert tuple(path[0]) == (0, 0) and tuple(path[-1]) == (n - 1, m - 1)


def test_multiscale_recovers_a_known_warp_and_matches_the_exact_dtw():
    rng = np.random.default_rng(2)
    A = _unit(rng.normal(size=(1500, 12)))
    tempo = 1.0 + 0.4 * np.sin(np.linspace(0, 6, 2200))             # slows down and speeds up (within 1/3..3)
    src = np.clip(np.cumsum(tempo) / tempo.sum() * 1500, 0, 1499).astype(int)  # reference frame -> query row
    lead = _unit(rng.normal(size=(300, 12)))                           # unrelated material first
    B = np.concatenate([lead, _unit(A[src] + 0.3 * rng.normal(size=(len(src), 12)))])
    path, cost = multiscale_dtw(A, B, skip_cost=0.9, max_cells=200_000)  # two coarse levels, then a band
    _, exact = dtw(A, B, None, 0.9)
    assert cost == pytest.approx(exact, rel=1e-3)
    truth: dict[int, int] = {}
    for j, i in enumerate(src):
        truth.setdefault(i, j + 300)
    first: dict[int, int] = {}
    for i, j in path:
        first.setdefault(i, j)
    err = np.array([abs(first[i] - truth[i]) for i in truth])
    assert np.median(err) <= 1 and np.percentile(err, 99) <= 3
    assert 295 <= path[0][1] <= 305  # the unrelated lead-in is skipped, not matched
