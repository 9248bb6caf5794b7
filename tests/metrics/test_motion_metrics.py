import numpy as np
import pytest

from gesturelsm.metrics.diversity import l1_diversity
from gesturelsm.metrics.face import expression_mse
from gesturelsm.metrics.physics import jitter


def test_diversity_of_a_static_pose_is_zero_and_matches_hand_computation():
    pose = np.random.default_rng(0).normal(size=(1, 55, 3))
    assert l1_diversity(np.repeat(pose, 50, 0)) == pytest.approx(0.0, abs=1e-12)
    j = np.repeat(pose, 4, 0).copy()
    j[:, 20, 0] += np.array([-1.0, 1.0, -1.0, 1.0])     # one coordinate swings +-1 around its mean
    assert l1_diversity(j) == pytest.approx(1.0)
    j[:, 21, 1] += np.array([2.0, -2.0, 2.0, -2.0])     # L1 sums over joints and axes
    assert l1_diversity(j) == pytest.approx(3.0)


def test_diversity_grows_with_amplitude():
    t = np.arange(300)[:, None, None] / 30
    base = np.sin(2 * np.pi * 0.5 * t) * np.ones((1, 55, 3))
    assert l1_diversity(2 * base) == pytest.approx(2 * l1_diversity(base))


def test_jitter_is_zero_for_constant_velocity_and_sees_noise():
    t = np.arange(100)[:, None, None] / 30
    line = t * np.ones((1, 55, 3))
    assert jitter(line) == pytest.approx(0.0, abs=1e-6)
    noisy = line + np.random.default_rng(0).normal(scale=1e-3, size=line.shape)
    assert jitter(noisy) > 1.0


def test_expression_mse():
    a = np.zeros((10, 100))
    b = np.ones((12, 100)) * 2
    assert expression_mse(a, b) == pytest.approx(4.0)
