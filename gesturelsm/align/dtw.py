"""Slope-constrained dynamic time warping with open ends, on a band, and a coarse-to-fine driver.

Conventions: `A` (N, D) is the query (synthetic speech), `B` (M, D) the reference (the user's audio), both
L2-normalised feature rows so that the local cost is the cosine distance 1 - a.b in [0, 2]. A path is an
(K, 2) int array of (i, j) cells, increasing in both columns, including the cells a long step jumps over.

Steps (di, dj) in {(1,1), (1,2), (2,1), (1,3), (3,1)} bound the local slope to [1/3, 3]; each step is
weighted so that every path from (0,0) to (N-1, M-1) carries the same total weight N + M, which removes the
usual bias towards the diagonal. Open ends: the path may start at (i0, 0) or (0, j0) and end at (N-1, j1) or
(i1, M-1); every skipped frame costs `skip_cost` (a "garbage" match), which absorbs music or noise before
and after the speech, and transcript words with no speech at the ends. Optional gap steps (1, 0) and (0, 1)
at `gap_cost` per frame leave frames unmatched inside the path.
"""
from __future__ import annotations

import numpy as np

# (di, dj): rows advance di, columns dj; the step visits max(di, dj) cells, each weighted (di + dj) / cells
STEPS: tuple[tuple[int, int], ...] = ((1, 1), (1, 2), (2, 1), (1, 3), (3, 1))
_START, _VGAP, _HGAP = -1, -2, -3  # step-table markers: path starts here; gap steps (1, 0) and (0, 1)


def _step_cells(di: int, dj: int) -> list[tuple[int, int]]:
    """Offsets (back from the arrival cell) of the cells a step visits, the arrival cell first."""
    n = max(di, dj)
    if di == dj:
        return [(0, 0)]
    if di < dj:  # one diagonal move, then horizontal moves
        return [(0, -k) for k in range(n)]
    return [(-k, 0) for k in range(n)]


class Band:
    """Column window [lo[i], hi[i]) per query row i; `width` is the stored width of every row."""

    def __init__(self, lo: np.ndarray, hi: np.ndarray, m: int):
        self.lo = np.clip(lo.astype(np.int64), 0, m - 1)
        self.hi = np.clip(hi.astype(np.int64), self.lo + 1, m)
        self.m = m
        self.width = int((self.hi - self.lo).max())

    @classmethod
    def full(cls, n: int, m: int) -> Band:
        return cls(np.zeros(n, np.int64), np.full(n, m, np.int64), m)


def dtw(A: np.ndarray, B: np.ndarray, band: Band | None = None, skip_cost: float | None = None,
        gap_cost: float | None = None) -> tuple[np.ndarray, float]:
    """Best path and its cost per unit weight (mean cosine distance along the path, skips included).
    ValueError when no path fits (only possible without `skip_cost`: lengths more than 3x apart).

    The local costs of each query row over its band are one matrix-vector product each; the recursion over the
    cells runs compiled (`_dtw_kernel.accumulate`, numba), cell by cell in the order and with the operations of a
    row-vectorised numpy recursion, so its results are those of that recursion to the bit (tests/align hold it to
    one). Step choices are kept in band coordinates (int8, N x band width) for the backtrack."""
    n, m = len(A), len(B)
    band = band or Band.full(n, m)
    lo, hi = band.lo, band.hi
    cost = np.full((n, band.width), np.inf)
    for i in range(n):
        a, b = int(lo[i]), int(hi[i])
        cost[i, : b - a] = np.maximum(1.0 - B[a:b] @ A[i], 0.0)   # (W,) cosine distances of query row i
    arg, last_row, last_col = _compiled()(cost, lo, hi, m, np.inf if skip_cost is None else float(skip_cost),
                                          skip_cost is not None, 0.0 if gap_cost is None else float(gap_cost),
                                          gap_cost is not None, np.result_type(A, B) == np.float32)
    return _backtrack(arg, band, last_row, last_col, n, m, skip_cost)


def _compiled():
    """The recursion compiled by numba (`_dtw_kernel.py`; imported on first use: numba takes ~0.4 s to import, and the
    compiled code is cached on disk, so only the first process ever compiles it, ~2 s)."""
    from ._dtw_kernel import accumulate

    return accumulate


def warm() -> None:
    """Compile the recursion (or load it from the disk cache) ahead of its first use, so that a server's first visitor
    does not wait for it."""
    A = np.eye(4)[:3]
    dtw(A, A, None, 0.6, 0.9)


def _backtrack(arg: np.ndarray, band: Band, last_row: np.ndarray, last_col: np.ndarray, n: int, m: int,
               skip_cost: float | None) -> tuple[np.ndarray, float]:
    lo = band.lo
    tail_j = np.arange(m - 1, -1, -1, dtype=float)  # reference frames skipped after (n-1, j)
    end_row = last_row + (np.where(tail_j == 0, 0.0, skip_cost * tail_j) if skip_cost is not None
                          else np.where(tail_j == 0, 0.0, np.inf))
    j_best = int(np.argmin(end_row))
    total, i, j = float(end_row[j_best]), n - 1, j_best
    if skip_cost is not None:  # or end at (i1, m-1), skipping the query's tail
        end_col = last_col + skip_cost * np.arange(n - 1, -1, -1)
        i_best = int(np.argmin(end_col))
        if end_col[i_best] < total:
            total, i, j = float(end_col[i_best]), i_best, m - 1
    if not np.isfinite(total):
        raise ValueError("no warping path fits the band (the sequences' lengths are too different)")
    path = [(i, j)]
    while True:
        s = int(arg[i, j - lo[i]])
        if s == _START:
            break
        di, dj = (1, 0) if s == _VGAP else (0, 1) if s == _HGAP else STEPS[s]
        for oi, oj in _step_cells(di, dj)[1:] if s >= 0 else ():
            path.append((i + oi, j + oj))
        i, j = i - di, j - dj
        path.append((i, j))
    return np.array(path[::-1], np.int64), total / (n + m)


def downsample(X: np.ndarray, f: int) -> np.ndarray:
    """Average blocks of f rows (first axis), then re-normalise feature vectors (last axis) to unit length."""
    n = (len(X) + f - 1) // f
    pad = np.concatenate([X, np.repeat(X[-1:], n * f - len(X), 0)])
    Y = pad.reshape(n, f, *X.shape[1:]).mean(1)
    return Y / np.maximum(np.linalg.norm(Y, axis=-1, keepdims=True), 1e-8)


def band_around(path: np.ndarray, f: int, n: int, m: int, radius: int) -> Band:
    """Fine-level band: the coarse path scaled by f, widened by `radius` fine frames on each side."""
    lo = np.full(n, m, np.int64)
    hi = np.zeros(n, np.int64)
    for ci, cj in path:  # coarse cell -> f x f block of fine cells
        r0, r1 = ci * f, min(n, ci * f + f)
        lo[r0:r1] = np.minimum(lo[r0:r1], cj * f)
        hi[r0:r1] = np.maximum(hi[r0:r1], cj * f + f)
    lo = np.minimum.accumulate(lo[::-1])[::-1]  # rows the coarse path did not reach keep a valid window
    hi = np.maximum.accumulate(hi)
    return Band(lo - radius, hi + radius, m)


def multiscale_dtw(A: np.ndarray, B: np.ndarray, skip_cost: float | None = None, gap_cost: float | None = None,
                   max_cells: int = 1_500_000, radius: int = 25, factor: int = 4) -> tuple[np.ndarray, float]:
    """Coarse-to-fine DTW: a full DTW on block-averaged features small enough for `max_cells`, then a band
    of `radius` frames around the projected path at each finer level. Cost O((N + M) * radius) per level."""
    if len(A) * len(B) <= max_cells:
        return dtw(A, B, None, skip_cost, gap_cost)
    path, _ = multiscale_dtw(downsample(A, factor), downsample(B, factor), skip_cost, gap_cost, max_cells, radius,
                             factor)
    band = band_around(path, factor, len(A), len(B), radius)
    return dtw(A, B, band, skip_cost, gap_cost)
