"""`gesturelsm eval`'s GENEA Leaderboard columns (FD_g, FD_k, DIV_k, DIV_sample: metrics/leaderboard.py), the same
definitions `gesturelsm genea metrics` uses, with a clip's seeds as its samples."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.evaluation.evaluate import MotionStats, genea_columns
from gesturelsm.metrics import leaderboard as lb


def _stats(poses, clip=""):
    return MotionStats(0.0, 0.0, 0.0, {}, poses=poses, clip=clip)


def test_genea_columns_are_the_leaderboards_definitions():
    rng = np.random.default_rng(0)
    gt = [rng.normal(size=(80, 165)) for _ in range(3)]
    gen = {f"c{k}": [rng.normal(size=(70 + s, 165)) * 1.1 for s in range(2)] for k in range(3)}
    stats = [_stats(p, c) for c, ps in gen.items() for p in ps]
    out = genea_columns(stats, [_stats(g) for g in gt])
    every = [p for ps in gen.values() for p in ps]
    assert out["fid_g"] == pytest.approx(lb.fd_g(gt, every)) and out["fid_k"] == pytest.approx(lb.fd_k(gt, every))
    assert out["var_k"] == pytest.approx(np.mean([np.var(p, axis=0).mean() for p in every]))
    n = [min(len(p) for p in ps) for ps in gen.values()]
    want = np.mean([np.var(np.stack([p[:m] for p in ps]), axis=0).mean() for ps, m in zip(gen.values(), n)])
    assert out["sample_div"] == pytest.approx(want)
    one_seed = genea_columns([_stats(ps[0], c) for c, ps in gen.items()], None)
    assert one_seed["sample_div"] is None and one_seed["fid_g"] is None and one_seed["var_k"] > 0
