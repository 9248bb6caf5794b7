"""The compiled DTW recursion (gesturelsm/align/dtw.py) against the row-vectorised numpy recursion it replaced, kept
here as the oracle: the same paths and costs to the bit, on random features with every option and on bands, and on
the aligner's own features of real speech."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.align.dtw import STEPS, Band, _backtrack, band_around, downsample, dtw, multiscale_dtw

_START, _VGAP, _HGAP = -1, -2, -3


def _unit(x: np.ndarray) -> np.ndarray:
    return (x / np.linalg.norm(x, axis=-1, keepdims=True)).astype(np.float32)


def numpy_dtw(A: np.ndarray, B: np.ndarray, band: Band | None = None, skip_cost: float | None = None,
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



def _same(A, B, band, skip, gap):
    try:
        want = numpy_dtw(A, B, band, skip, gap)
    except ValueError:
        with pytest.raises(ValueError):
            dtw(A, B, band, skip, gap)
        return 0
    path, cost = dtw(A, B, band, skip, gap)
    assert cost == want[1]                         # to the bit, not approximately
    np.testing.assert_array_equal(path, want[0])
    return 1


@pytest.mark.parametrize("skip, gap", [(None, None), (0.6, None), (0.6, 0.9), (None, 0.5)])
def test_the_compiled_recursion_gives_the_numpy_recursions_paths_and_costs(skip, gap):
    rng = np.random.default_rng(7)
    found = 0
    for _ in range(40):
        n, m = rng.integers(2, 40, size=2)
        A, B = _unit(rng.normal(size=(n, 6))), _unit(rng.normal(size=(m, 6)))
        found += _same(A, B, None, skip, gap)
    assert found >= 20                             # most shapes have a path: the comparison is not vacuous


@pytest.mark.parametrize("skip, gap", [(0.9, None), (0.9, 0.9)])
def test_on_a_band_from_a_coarse_path_too(skip, gap):
    rng = np.random.default_rng(8)
    A = _unit(rng.normal(size=(300, 8)))
    B = _unit(np.repeat(A, 2, axis=0)[:500] + 0.2 * rng.normal(size=(500, 8)))
    coarse, _ = numpy_dtw(downsample(A, 4), downsample(B, 4), None, skip, gap)
    band = band_around(coarse, 4, len(A), len(B), 6)
    assert band.width < len(B) // 2                # a real band, not the full matrix
    assert _same(A, B, band, skip, gap) == 1


def test_on_the_aligners_features_of_real_speech(beat2_root, espeak):
    from gesturelsm.align.features import mfcc_rows
    from gesturelsm.align.tts import synthesize
    from gesturelsm.audio import load_audio

    y = load_audio(beat2_root / "wave16k" / "2_scott_0_3_3.wav")[: 12 * 16000]
    syn = synthesize("the first thing i like to do on weekends is relaxing and i think i will go shopping".split())[0]
    A, B = mfcc_rows(syn.audio, syn.sr), mfcc_rows(y)
    assert _same(A, B, None, 0.9, 0.9) == 1
    path, cost = multiscale_dtw(A, B, 0.9, 0.9, max_cells=50_000)      # the driver's bands, end to end
    assert np.isfinite(cost) and len(path) >= len(A)
