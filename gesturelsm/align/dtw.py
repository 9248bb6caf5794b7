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

    Rows are processed one at a time, each vectorised over its band; accumulated and local costs of the
    last few rows are kept in full-width buffers (so every step is a slice), step choices in band
    coordinates (int8, N x band width) for the backtrack."""
    n, m = len(A), len(B)
    band = band or Band.full(n, m)
    lo, hi = band.lo, band.hi
    pad = max(dj for _, dj in STEPS)  # column j lives at j + pad: predecessors never index below zero
    R = max(di for di, _ in STEPS) + 1  # rows kept
    D = np.full((R, m + pad), np.inf)
    C = np.full((R, m + pad), np.inf)
    arg = np.full((n, band.width), _START, np.int8)
    last_col = np.full(n, np.inf)  # D[i, m - 1], for ends that skip the query's tail
    last_row = np.full(m, np.inf)  # D[n - 1, j]
    skip = skip_cost
    for i in range(n):
        a, b = int(lo[i]), int(hi[i])
        cur = i % R
        if i >= R:  # forget row i - R
            pa, pb = int(lo[i - R]), int(hi[i - R])
            D[cur, pa + pad:pb + pad] = np.inf
            C[cur, pa + pad:pb + pad] = np.inf
        c = np.maximum(1.0 - B[a:b] @ A[i], 0.0)  # (W,) cosine distances of query row i in its band
        C[cur, a + pad:b + pad] = c
        j = np.arange(a, b)
        if i == 0:  # start at (0, j) after skipping j reference frames
            best = 2.0 * c + (np.where(j == 0, 0.0, skip * j) if skip is not None else np.where(j == 0, 0.0, np.inf))
        elif skip is not None and a == 0:  # start at (i, 0) after skipping i query frames
            best = np.full(b - a, np.inf)
            best[0] = 2.0 * c[0] + skip * i
        else:
            best = np.full(b - a, np.inf)
        choice = np.full(b - a, _START, np.int8)
        for s_idx, (di, dj) in enumerate(STEPS):
            if i - di < 0:
                continue
            prev = D[(i - di) % R, a - dj + pad:b - dj + pad]
            if di == dj:
                add = 2.0 * c
            elif di < dj:
                add = sum(C[cur, a - k + pad:b - k + pad] for k in range(dj)) * ((di + dj) / dj)
            else:
                add = sum(C[(i - k) % R, a + pad:b + pad] for k in range(di)) * ((di + dj) / di)
            cand = prev + add
            better = cand < best
            best = np.where(better, cand, best)
            choice[better] = s_idx
        if gap_cost is not None:
            if i > 0:  # vertical gap step: query frame i matches nothing
                cand = D[(i - 1) % R, a + pad:b + pad] + gap_cost
                better = cand < best
                best = np.where(better, cand, best)
                choice[better] = _VGAP
            # horizontal gap steps: reference frames matched to nothing, D[j] = min_k<=j D'[k] + g (j - k)
            run = np.minimum.accumulate(best - gap_cost * j) + gap_cost * j
            better = run < best - 1e-12
            best = np.where(better, run, best)
            choice[better] = _HGAP
        D[cur, a + pad:b + pad] = best
        arg[i, : b - a] = choice
        if b == m:
            last_col[i] = best[-1]
        if i == n - 1:
            last_row[a:b] = best
    return _backtrack(arg, band, last_row, last_col, n, m, skip_cost)


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
