"""Study statistics against known truths: Bradley-Terry scores and their bootstrap intervals on responses drawn
from known strengths (coverage near 95% over many simulated studies), Wilson coverage, Holm's correction and
the sign test on hand-checked values, and attention checks on a made-up rater."""
from __future__ import annotations

import numpy as np
import pytest

TRUE = np.array([0.0, 0.6, 1.1, -0.5])           # log-strengths, reference (index 0) = 0


def _simulate(rng, raters: int = 30, per_pair: int = 4) -> np.ndarray:
    """(raters, M, M) win counts: every rater judges every pair `per_pair` times under Bradley-Terry."""
    m = len(TRUE)
    i, j = np.triu_indices(m, 1)
    p = 1 / (1 + np.exp(TRUE[j] - TRUE[i]))
    won = (rng.random((raters, per_pair, len(i))) < p).sum(1)
    w = np.zeros((raters, m, m))
    w[:, i, j], w[:, j, i] = won, per_pair - won
    return w


def test_bradley_terry_recovers_strengths_and_intervals_cover_them():
    from gesturelsm.study.stats import bradley_terry, bt_bootstrap

    rng = np.random.default_rng(0)
    big = _simulate(rng, raters=2000).sum(0)
    assert np.abs(bradley_terry(big, prior=0.0) - TRUE).max() < 0.06       # consistent on a huge study
    covered, est = [], []
    for k in range(150):
        s = bt_bootstrap(_simulate(rng), n_boot=200, seed=k)
        assert s.score[0] == 0 and (s.low <= s.score).all() and (s.score <= s.high).all()
        covered.append((s.low[1:] <= TRUE[1:]) & (TRUE[1:] <= s.high[1:]))
        est.append(s.score[1:])
    rate = np.mean(covered)                      # 450 intervals: nominal 0.95, binomial sd ~0.01
    assert 0.88 <= rate <= 0.99, rate
    assert np.abs(np.mean(est, 0) - TRUE[1:]).max() < 0.05     # nearly unbiased


def test_a_method_that_never_wins_gets_a_finite_lowest_score():
    from gesturelsm.study.stats import bradley_terry

    w = np.array([[0, 5, 5], [0, 0, 3], [0, 2, 0]], float)
    s = bradley_terry(w)
    assert np.isfinite(s).all() and s[0] == 0 and s.argmax() == 0


def test_wilson_covers_proportions_at_the_nominal_rate():
    from gesturelsm.study.stats import wilson

    rng = np.random.default_rng(1)
    hits = 0
    for _ in range(2000):
        p = rng.uniform(0.1, 0.9)
        lo, hi = wilson(rng.binomial(40, p), 40)
        hits += lo <= p <= hi
    assert 0.93 <= hits / 2000 <= 0.97
    assert wilson(0, 10)[0] == 0 and wilson(10, 10)[1] == pytest.approx(1)
    assert np.allclose(wilson(5, 10), (0.2366, 0.7634), atol=1e-4)


def test_holm_and_sign_test_match_hand_computed_values():
    from gesturelsm.study.stats import holm, sign_test

    assert np.allclose(holm([0.01, 0.04, 0.03, 0.005]), [0.03, 0.06, 0.06, 0.02])
    assert sign_test(9, 1) == pytest.approx(22 / 1024)          # 2 * P(X >= 9), X ~ Bin(10, 1/2)
    assert sign_test(0, 0) == 1.0


def test_attention_checks_judge_a_rater():
    from gesturelsm.study.design import Rater, Trial
    from gesturelsm.study.results import Rule, check_rater

    trials = [Trial(0, "pair", "a", "b"), Trial(1, "pair", "g", "m", check="mismatch", expect="left"),
              Trial(2, "pair", "b", "a", check="repeat", of=0)]
    rater = Rater(7, "t", trials)
    consistent = {0: dict(choice="left"), 1: dict(choice="left"), 2: dict(choice="right")}   # "a" both times
    c = check_rater(rater, consistent, Rule())
    assert c.kept and c.mismatch == (1, 1) and c.repeat == (1, 1)
    fooled = {0: dict(choice="left"), 1: dict(choice="right"), 2: dict(choice="left")}
    c = check_rater(rater, fooled, Rule())
    assert not c.kept and c.mismatch == (0, 1) and c.repeat == (0, 1) and "mismatch 0/1" in c.reason
    assert check_rater(rater, fooled, Rule(0.0, 0.0, 0)).kept
    changed_mind = {0: dict(choice="left"), 1: dict(choice="left"), 2: dict(choice="left")}
    assert check_rater(rater, changed_mind, Rule()).kept                    # repeats drop nobody by default
    assert not check_rater(rater, changed_mind, Rule(repeat_pass=0.5)).kept
    assert not check_rater(rater, {0: dict(choice="left")}, Rule()).kept        # no check answered
