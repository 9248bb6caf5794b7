"""The DTW recursion of `dtw.dtw`, compiled by numba (imported only when an alignment runs). Conventions are
dtw.py's: costs and accumulated costs in band coordinates (row i holds columns lo[i]..hi[i]), step choices as indices
into dtw.STEPS or the markers below.
"""
from __future__ import annotations

import numba
import numpy as np

_START, _VGAP, _HGAP = -1, -2, -3  # dtw.py's step-table markers: path starts here; gap steps (1, 0) and (0, 1)


@numba.njit(cache=True, nogil=True)
def accumulate(cost, lo, hi, m, skip, has_skip, gap, has_gap, single):
    """The recursion of `dtw` over the band: step choices (N, width) int8, the last row D[N-1, :] and the last column
    D[:, M-1] (inf outside the band). Each cell takes the best of: a start (first row, or first column with skips),
    each of STEPS in their order (a step's cells' costs summed arrival cell first, weighted (di + dj) / cells), a
    vertical gap, then horizontal gaps (a running minimum over the row); ties keep the earlier candidate. Rows
    before the first have an empty band (every lookup there is inf)."""
    n, width = cost.shape
    inf = np.inf
    D = np.full((n, width), inf)
    arg = np.full((n, width), _START, np.int8)
    last_col = np.full(n, inf)
    last_row = np.full(m, inf)
    best = np.empty(width)
    w12, w13 = 3 / 2, 4 / 3                       # (di + dj) / cells of the two- and three-cell steps
    for i in range(n):
        a, b = lo[i], hi[i]
        l1, h1 = (lo[i - 1], hi[i - 1]) if i >= 1 else (0, 0)
        l2, h2 = (lo[i - 2], hi[i - 2]) if i >= 2 else (0, 0)
        l3, h3 = (lo[i - 3], hi[i - 3]) if i >= 3 else (0, 0)
        for j in range(a, b):
            c = cost[i, j - a]
            if i == 0:
                v = 2.0 * c + (0.0 if j == 0 else (skip * j if has_skip else inf))
            elif has_skip and a == 0 and j == 0:
                v = 2.0 * c + skip * i
                if single:                 # the numpy recursion summed this start in float32 for float32 features
                    v = np.float64(np.float32(np.float32(2.0 * c) + np.float32(skip * i)))
            else:
                v = inf
            choice = _START
            c1 = cost[i, j - 1 - a] if j - 1 >= a else inf          # the row's own cells to the left
            c2 = cost[i, j - 2 - a] if j - 2 >= a else inf
            u1 = cost[i - 1, j - l1] if l1 <= j < h1 else inf       # the cells above
            u2 = cost[i - 2, j - l2] if l2 <= j < h2 else inf
            cand = (D[i - 1, j - 1 - l1] if l1 <= j - 1 < h1 else inf) + 2.0 * c                    # (1, 1)
            if cand < v:
                v, choice = cand, 0
            cand = (D[i - 1, j - 2 - l1] if l1 <= j - 2 < h1 else inf) + (0.0 + c + c1) * w12       # (1, 2)
            if cand < v:
                v, choice = cand, 1
            if i >= 2:
                cand = (D[i - 2, j - 1 - l2] if l2 <= j - 1 < h2 else inf) + (0.0 + c + u1) * w12   # (2, 1)
                if cand < v:
                    v, choice = cand, 2
            cand = (D[i - 1, j - 3 - l1] if l1 <= j - 3 < h1 else inf) + (0.0 + c + c1 + c2) * w13  # (1, 3)
            if cand < v:
                v, choice = cand, 3
            if i >= 3:
                cand = (D[i - 3, j - 1 - l3] if l3 <= j - 1 < h3 else inf) + (0.0 + c + u1 + u2) * w13  # (3, 1)
                if cand < v:
                    v, choice = cand, 4
            if has_gap and i > 0:
                cand = (D[i - 1, j - l1] if l1 <= j < h1 else inf) + gap
                if cand < v:
                    v, choice = cand, _VGAP
            best[j - a] = v
            arg[i, j - a] = choice
        if has_gap:
            run = inf
            for j in range(a, b):
                run = min(run, best[j - a] - gap * j)
                cand = run + gap * j
                if cand < best[j - a] - 1e-12:
                    best[j - a] = cand
                    arg[i, j - a] = _HGAP
        for j in range(a, b):
            D[i, j - a] = best[j - a]
        if b == m:
            last_col[i] = best[b - 1 - a]
        if i == n - 1:
            for j in range(a, b):
                last_row[j] = best[j - a]
    return arg, last_row, last_col
