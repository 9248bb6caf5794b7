"""Feet and root measures (metrics/feet.py) against hand-made joints whose answers are known, and the speaker's real
take against the figures the measures are quoted with."""
from __future__ import annotations


import numpy as np
import pytest

from gesturelsm.metrics.feet import FOOT_JOINTS, LEG_JOINTS, feet_stats, floor_height, foot_skate, path_diameter
from _support import BEAT2

TAKE = BEAT2 / "smplxflame_30" / "2_scott_0_1_1.npz"


def standing(T: int = 300) -> np.ndarray:
    """A still body: pelvis at 0.95 m, ankles 7.5 cm and toes 5 cm above y = 0."""
    j = np.zeros((T, 55, 3))
    j[:, :, 1] = 1.2
    j[:, 0, 1] = 0.95
    j[:, [7, 8], 1] = 0.075
    j[:, [10, 11], 1] = 0.05
    j[:, [7, 10], 0] = 0.1
    j[:, [8, 11], 0] = -0.1
    return j


def test_a_still_standing_body_measures_zero_everywhere_and_full_contact():
    s = feet_stats(standing())
    assert s.foot_skate == 0.0 and s.contact_share == 1.0
    assert s.root_drift == 0.0 and s.root_range == 0.0 and s.bob == 0.0 and s.penetration == 0.0 and s.leg_jerk == 0.0


def test_foot_skate_is_the_mean_horizontal_speed_of_the_low_joints_only_in_cm_per_s():
    j = standing()
    T = len(j)
    j[:, [10, 11], 0] += np.arange(T)[:, None] * 0.01             # toes glide at 0.3 m/s on the floor
    j[:, 8, 2] += np.arange(T) * 0.02                               # the right ankle moves fast ...
    j[:, 8, 1] = 0.2                                                # ... but 15 cm up: not counted, not in contact
    skate, share = foot_skate(j)
    assert skate == pytest.approx(100 * (0.3 + 0.3 + 0.0) / 3)      # toes 30 cm/s, left ankle still
    assert share == pytest.approx(0.75)
    assert feet_stats(j).foot_skate == pytest.approx(skate)


def test_the_floor_is_the_takes_own_so_a_raised_motion_measures_the_same():
    j = standing()
    j[:, [10, 11], 0] += np.sin(np.arange(len(j)) / 7.0)[:, None] * 0.05
    up = j.copy()
    up[:, :, 1] += 0.4
    assert floor_height(up) == pytest.approx(floor_height(j) + 0.4)
    a, b = feet_stats(j).as_dict(), feet_stats(up).as_dict()
    assert a == pytest.approx(b)


def test_root_drift_range_and_bob():
    T = 1800                                                        # one minute
    j = standing(T)
    t = np.arange(T) / 30
    j[:, 0, 0] += 0.5 * t / t[-1]                                   # walks 0.5 m to the side in the minute ...
    j[:, 0, 2] += 0.3 * np.sin(2 * np.pi * t / 20)                  # ... swaying 0.3 m back and forth
    j[:, 0, 1] += 0.02 * np.sin(2 * np.pi * t)                      # bobbing 2 cm at 1 Hz
    s = feet_stats(j)
    xz = j[:, 0, [0, 2]]
    assert s.root_drift == pytest.approx(np.hypot(0.5, xz[-1, 1] - xz[0, 1]), rel=1e-9)
    assert s.drift_per_min == pytest.approx(s.root_drift / (T / 30 / 60))
    exact = max(np.linalg.norm(xz[i] - xz, axis=1).max() for i in range(0, T, 1))
    assert s.root_range == pytest.approx(exact, rel=1e-4) and s.root_range > 0.6
    assert s.bob == pytest.approx(100 * 0.02 / np.sqrt(2), rel=1e-3)


def test_path_diameter_is_rotation_invariant():
    rng = np.random.default_rng(0)
    p = rng.normal(size=(200, 2))
    a = 0.7
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    exact = max(np.linalg.norm(p[i] - p, axis=1).max() for i in range(len(p)))
    assert path_diameter(p) == pytest.approx(exact, rel=5e-5)
    assert path_diameter(p @ rot.T) == pytest.approx(exact, rel=5e-5)


def test_penetration_is_how_deep_the_lowest_frames_go_below_the_floor():
    j = standing(1000)
    j[::50, 11, 1] = 0.05 - 0.03                                   # 2 % of the frames: a toe 3 cm into the floor
    s = feet_stats(j)
    assert s.penetration == pytest.approx(3.0)
    j[::50, 11, 1] = 0.05 + 0.03                                   # above the floor: nothing below it
    assert feet_stats(j).penetration == 0.0


def test_leg_jerk_sees_only_the_legs():
    j = standing()
    noisy = j.copy()
    noisy[:, 20:22] += np.random.default_rng(1).normal(scale=0.01, size=noisy[:, 20:22].shape)   # wrists shake
    assert feet_stats(noisy).leg_jerk == 0.0
    noisy[:, list(LEG_JOINTS)] += np.random.default_rng(2).normal(scale=0.001, size=(len(j), len(LEG_JOINTS), 3))
    assert feet_stats(noisy).leg_jerk > 10.0


def test_short_and_empty_motions_give_nan_not_errors():
    assert np.isnan(feet_stats(standing(3)).leg_jerk) and feet_stats(standing(3)).foot_skate == 0.0
    one = feet_stats(standing(1))
    assert np.isnan(one.foot_skate) and np.isnan(one.root_drift) and one.bob == 0.0
    assert np.isnan(feet_stats(np.zeros((0, 55, 3))).bob)
    with pytest.raises(ValueError):
        feet_stats(np.zeros((10, 3)))
    assert FOOT_JOINTS == (7, 8, 10, 11)


def test_the_real_take_measures_as_quoted():
    """The speaker's own take on the shipped mannequin: the figures the docs and the issue quote."""
    if not TAKE.exists():
        pytest.skip(f"{TAKE} is absent (the real BEAT2 take lives in ../shared)")
    from gesturelsm.evaluation.motion_stats import stats_body
    from gesturelsm.motion import MotionSequence

    seq = MotionSequence.load(TAKE)
    s = feet_stats(stats_body().joints(seq.poses, seq.trans))
    assert s.foot_skate == pytest.approx(6.4, abs=0.05)
    assert s.root_drift == pytest.approx(0.15, abs=0.005) and s.root_range == pytest.approx(1.27, abs=0.01)
    assert s.bob == pytest.approx(2.6, abs=0.05) and s.contact_share == pytest.approx(0.59, abs=0.01)
