"""Drift out of the root's horizontal path (grounding/drift.py): a steady walk goes, sway stays, the standing area
is bounded; the causal form gives the same whether fed in chunks or frame by frame."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.grounding.drift import DriftParams, DriftRemover, OnePole, limit, remove_drift, smooth


def path(seconds: float = 60.0, walk: float = 0.05, sway: float = 0.08, period: float = 2.0) -> np.ndarray:
    t = np.arange(int(seconds * 30)) / 30
    return np.stack([walk * t + sway * np.sin(2 * np.pi * t / period), -0.5 * walk * t], 1)


def test_a_steady_walk_is_removed_and_a_weight_shift_kept():
    xz = path()
    out = remove_drift(xz, DriftParams(seconds=4.0, radius=10.0))          # no area limit: the filter alone
    assert np.linalg.norm(out[-1] - out[0]) < 0.02                         # walked 3.4 m; ends where it began
    sway = out[:, 0] - out[:, 0].mean()
    t = np.arange(len(xz)) / 30
    kept = 2 * np.mean(sway[300:-300] * np.sin(2 * np.pi * t[300:-300] / 2.0))   # amplitude of the 2 s sway
    assert kept == pytest.approx(0.08, rel=0.05)


def test_the_standing_area_is_bounded_and_small_moves_are_untouched():
    c = np.zeros(2)
    far = np.array([[5.0, 0.0], [0.0, -3.0]])
    assert np.linalg.norm(limit(far, c, 0.5), axis=1).max() < 0.5
    near = np.array([[0.01, 0.0]])
    np.testing.assert_allclose(limit(near, c, 0.5), near, rtol=1e-3)
    out = remove_drift(path(walk=0.0, sway=2.0, period=20.0), DriftParams(seconds=60.0, radius=0.5))
    assert np.linalg.norm(out - out.mean(0), axis=1).max() < 0.5


def test_the_causal_forms_give_the_same_in_chunks_and_frame_by_frame():
    xz = path(seconds=10.0)
    whole = DriftRemover().run(xz)
    chunked = DriftRemover()
    parts = np.concatenate([chunked.run(xz[a:a + 37]) for a in range(0, len(xz), 37)])
    np.testing.assert_allclose(parts, whole, atol=1e-12)
    one, many = OnePole(0.5), OnePole(0.5)
    np.testing.assert_allclose(np.array([one.step(x) for x in xz]), many.run(xz), atol=1e-12)
    lagging = DriftRemover(DriftParams(seconds=4.0, radius=10.0)).run(path(seconds=60.0, sway=0.0))
    assert np.linalg.norm(lagging[-1] - lagging[0]) == pytest.approx(np.hypot(0.05, 0.025) * 4.0, rel=0.05)


def test_smoothing_keeps_a_line_and_short_input():
    line = np.linspace(0, 3, 300)                                           # 10 s at 0.3 m/s
    np.testing.assert_allclose(smooth(line, 0.5), line, atol=1e-4)          # no lag (the one pass alone: 0.15 m)
    np.testing.assert_array_equal(smooth(np.array([1.0]), 0.5), [1.0])
