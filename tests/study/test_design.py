"""Study design: every pair of methods on every speech exactly once per rater, sides balanced within a rater,
mismatch checks in the second half pointing at the genuine video, repeats at least two trials after what they
repeat."""
from __future__ import annotations

from itertools import combinations

import pytest

METHODS = ["m0", "m1", "m2", "m3"]
SPEECHES = [f"s{k}" for k in range(5)]


@pytest.fixture
def cond():
    from gesturelsm.study.design import Conditions

    genuine = {f"v_{s}_{m}": (s, m) for s in SPEECHES for m in METHODS}
    mismatch = {f"x_{s}": (s, f"v_{SPEECHES[(k + 1) % 5]}_m0") for k, s in enumerate(SPEECHES)}
    return Conditions(genuine, mismatch)


def test_pairwise_trials_cover_every_pair_once_with_balanced_sides(cond):
    from gesturelsm.study.design import Design, rater_trials

    design = Design("pairwise", 0.2, seed=3)
    for rater in range(1, 9):
        trials = rater_trials(cond, design, rater)
        assert [t.index for t in trials] == list(range(len(trials)))
        real = [t for t in trials if not t.check]
        pairs = sorted((cond.genuine[t.left][0], *sorted((cond.genuine[t.left][1], cond.genuine[t.right][1])))
                       for t in real)
        assert pairs == sorted((s, a, b) for s in SPEECHES for a, b in combinations(METHODS, 2))
        assert all(cond.genuine[t.left][0] == cond.genuine[t.right][0] for t in real)   # same speech
        lefts = sum(METHODS.index(cond.genuine[t.left][1]) < METHODS.index(cond.genuine[t.right][1]) for t in real)
        assert abs(2 * lefts - len(real)) <= 1                       # balanced within the rater
        checks = [t for t in trials if t.check]
        assert len(checks) == 6 and {t.check for t in checks} == {"mismatch", "repeat"}   # ceil(0.2 * 30)
        for t in checks:
            if t.check == "mismatch":
                genuine_side = t.left if t.expect == "left" else t.right
                other = t.right if t.expect == "left" else t.left
                assert genuine_side == cond.mismatch[other][1]
            else:
                src = trials[t.of]
                assert t.of + 1 < t.index and not src.check and (t.left, t.right) == (src.right, src.left)
        assert min(t.index for t in checks if t.check == "mismatch") >= len(real) // 2   # in the second half


def test_rating_trials_show_every_video_once(cond):
    from gesturelsm.study.design import Design, rater_trials

    trials = rater_trials(cond, Design("rating", 0.1), 1)
    real = [t for t in trials if not t.check]
    assert sorted(t.left for t in real) == sorted(cond.genuine) and all(t.right == "" for t in trials)
    assert {t.kind for t in trials} == {"rating"}


def test_design_rejects_bad_settings():
    from gesturelsm.study.design import Design

    with pytest.raises(ValueError, match="unknown study design"):
        Design("ranking")
    with pytest.raises(ValueError, match="fraction"):
        Design("pairwise", 1.5)
