"""Amplitude statistics and the replay guard on synthetic motions whose answers are known."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.metrics.amplitude import (amplitude_stats, pooled_stats, replay_novelty, training_bank,
                                          wrist_heights)

FPS = 30


def still(T: int, pelvis_y: float = 0.9) -> np.ndarray:
    j = np.zeros((T, 55, 3))
    j[:, :, 1] = pelvis_y
    j[:, 20, 0], j[:, 21, 0] = 0.2, -0.2                     # wrists 0.4 m apart at pelvis height
    return j


def test_raised_share_heights_and_spread():
    j = still(100)
    j[:40, 20, 1] += 0.30                                      # left wrist raised for 40 of 100 frames
    j[60:70, 21, 1] += 0.40                                    # right wrist raised for 10 more
    j[70:, 21, 1] += 0.20                                      # below the 0.25 m line: not raised
    s = amplitude_stats(j)
    assert s.raised_share == pytest.approx(0.5)
    h = wrist_heights(j)
    assert h[:40, 0] == pytest.approx(0.30) and h[65, 1] == pytest.approx(0.40)
    assert s.height_p95 == pytest.approx(np.percentile(h.max(1), 95))
    assert s.hand_spread == pytest.approx(np.linalg.norm(j[:, 20] - j[:, 21], axis=-1).mean())


def test_speed_and_jerk_of_a_circle_match_calculus():
    T, r, w = 600, 0.15, 2 * np.pi * 1.5                       # 20 s, 15 cm radius, 1.5 Hz
    t = np.arange(T) / FPS
    j = still(T)
    j[:, 20, 0] += r * np.cos(w * t)
    j[:, 20, 1] += r * np.sin(w * t)
    s = amplitude_stats(j)
    assert s.wrist_speed == pytest.approx(r * w / 2, rel=0.02)          # one of two wrists moves at r w
    jerk_left = r * w ** 3                                               # |d3/dt3| of a circle
    assert s.jerk == pytest.approx(jerk_left / 13, rel=0.05)            # 1 of the 13 upper-body joints moves


def test_root_motion_is_not_gesture():
    rng = np.random.default_rng(0)
    j = still(200)
    j[:50, 21, 1] += 0.5
    moved = j + np.cumsum(rng.normal(0, 0.01, (200, 1, 3)), axis=0)      # whole body drifts and bobs
    a, b = amplitude_stats(j), amplitude_stats(moved)
    assert (b.raised_share, b.hand_spread) == pytest.approx((a.raised_share, a.hand_spread))
    assert b.height_p95 == pytest.approx(a.height_p95) and b.wrist_speed == pytest.approx(a.wrist_speed, abs=1e-9)


def test_pooled_weights_by_length():
    lo, hi = still(300), still(100)
    hi[:, 20, 1] += 0.5
    assert pooled_stats([lo, hi]).raised_share == pytest.approx(0.25)


def gestures(T: int, seed: int) -> np.ndarray:
    """Random smooth arm motion: sums of sinusoids with random phases (new for every seed)."""
    rng = np.random.default_rng(seed)
    t = np.arange(T)[:, None] / FPS
    j = still(T)
    for k in (16, 17, 18, 19, 20, 21):
        f, ph = rng.uniform(0.3, 2.0, (1, 3)), rng.uniform(0, 2 * np.pi, (1, 3))
        j[:, k] += 0.1 * np.sin(2 * np.pi * f * t + ph)
    return j


def test_replay_guard_catches_copies_and_passes_new_motion():
    train = gestures(900, 0)
    bank = training_bank([train])
    held_out = [gestures(300, 1)]
    copies = [train[100:400], train[500:800]]                           # a model that replays training clips
    assert replay_novelty(copies, bank, held_out).ratio < 0.05
    assert replay_novelty(held_out, bank, held_out).ratio == pytest.approx(1.0)
    new = replay_novelty([gestures(300, 2), gestures(300, 3)], bank, held_out)
    assert 0.5 < new.ratio < 2.0 and new.generated > 0


def test_bad_shapes_are_refused():
    with pytest.raises(ValueError, match="joint positions"):
        amplitude_stats(np.zeros((10, 24, 3)))
    with pytest.raises(ValueError, match="shorter"):
        training_bank([still(10)])
