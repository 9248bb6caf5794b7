import numpy as np
import pytest

from gesturelsm.metrics.fgd import GeometricExtractor, KineticExtractor, fgd
from gesturelsm.metrics.frechet import frechet_distance, gaussian_stats
from gesturelsm.metrics.motion_features import geometric_features, kinetic_features


def gesturing_joints(T: int = 400, seed: int = 0) -> np.ndarray:
    """Joints swinging smoothly around a rest skeleton (metres), a stand-in for motion capture."""
    rng = np.random.default_rng(seed)
    rest = rng.normal(scale=0.3, size=(1, 55, 3))
    t = np.arange(T)[:, None, None] / 30
    freq = rng.uniform(0.3, 2.0, (1, 55, 3))
    return rest + 0.05 * np.sin(2 * np.pi * freq * t + rng.uniform(0, 6, (1, 55, 3)))


def test_frechet_matches_closed_form_for_gaussians():
    # 1-D: FD = (m1 - m2)^2 + (s1 - s2)^2
    a = gaussian_stats(np.array([[0.0], [2.0]]))            # mean 1, var 1 (1/N)
    b = gaussian_stats(np.array([[3.0], [5.0], [4.0]]))     # mean 4, var 2/3
    assert frechet_distance(a, b) == pytest.approx(9 + (1 - np.sqrt(2 / 3)) ** 2)
    assert frechet_distance(np.tile(b.mean, (1, 1)).repeat(2, 0), b.mean[None].repeat(3, 0)) == 0.0
    # diagonal covariances in several dimensions, large samples
    rng = np.random.default_rng(0)
    x = rng.normal(0, 1, (20000, 3))
    y = rng.normal(1, 2, (20000, 3))
    assert frechet_distance(x, y) == pytest.approx(3 * 1 + 3 * (2 - 1) ** 2, rel=0.03)


def test_fgd_of_identical_sets_is_zero_even_with_fewer_samples_than_dims():
    rng = np.random.default_rng(1)
    f = rng.normal(size=(10, 51))                           # singular covariance
    assert frechet_distance(f, f) == pytest.approx(0.0, abs=1e-8)
    assert frechet_distance(f, f[::-1]) == pytest.approx(0.0, abs=1e-8)   # order does not matter
    assert frechet_distance(f, np.concatenate([f, f])) == pytest.approx(0.0, abs=1e-8)   # seeds repeating


@pytest.mark.parametrize("extractor", [KineticExtractor(), GeometricExtractor()])
def test_fgd_is_zero_for_the_same_motion_and_grows_with_noise(extractor):
    j = gesturing_joints()
    real = [extractor(None, j)]
    assert fgd(real, real) == pytest.approx(0.0, abs=1e-9)
    rng = np.random.default_rng(2)
    scores = [fgd(real, [extractor(None, j + rng.normal(scale=s, size=j.shape))]) for s in (0.002, 0.01, 0.05)]
    assert 0 < scores[0] < scores[1] < scores[2]


def test_kinetic_features_see_speed_and_ignore_translation():
    j = gesturing_joints()
    walk = j + np.linspace(0, 3, len(j))[:, None, None] * np.array([1.0, 0, 0])   # whole body drifting
    assert np.allclose(kinetic_features(j), kinetic_features(walk))
    assert np.allclose(geometric_features(j), geometric_features(walk))
    static = np.repeat(j[:1], len(j), 0)
    assert np.allclose(kinetic_features(static), 0)
    k = kinetic_features(j)
    assert k.shape == ((len(j) - 32) // 16 + 1, 51)
    fast = kinetic_features(j[::2])                                              # same path, twice the speed
    assert fast[:, :17].mean() > 3 * k[:, :17].mean()


def test_faster_motion_is_farther_than_same_style_motion():
    """A second take of the same motion style scores closer to the reference than a sped-up copy."""
    real = [KineticExtractor()(None, gesturing_joints(seed=0))]
    same_style = [KineticExtractor()(None, gesturing_joints(seed=0)[7:])]
    hurried = [KineticExtractor()(None, gesturing_joints(T=800, seed=0)[::3])]
    assert fgd(real, same_style) < fgd(real, hurried)


def test_normalised_fgd_is_unit_free():
    """Rescaling one feature (e.g. metres -> millimetres) changes the raw distance, not the normalised one."""
    rng = np.random.default_rng(3)
    r, g = rng.normal(size=(200, 4)), rng.normal(0.3, 1.2, size=(200, 4))
    scale = np.array([1000.0, 1, 1, 1])
    assert fgd([r], [g]) == pytest.approx(fgd([r * scale], [g * scale]), rel=1e-9)
    assert fgd([r], [g], normalize=False) != pytest.approx(fgd([r * scale], [g * scale], normalize=False))
