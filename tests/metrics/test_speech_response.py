import numpy as np
import pytest
from _support import joints_with_pauses

from gesturelsm.metrics.speech_response import beat_timing, energy_following, loudness


def joints_with_speed(speed: np.ndarray) -> np.ndarray:
    """(T-1,) speed (m/s) -> (T, 55, 3) joints moving along x at that speed."""
    pos = np.concatenate([[0.0], np.cumsum(speed) / 30.0])
    j = np.zeros((len(pos), 55, 3))
    j[:, :, 0] = pos[:, None]
    return j


def phrased_noise(seconds: float, seed: int) -> np.ndarray:
    """Noise whose loudness rises and falls irregularly (phrases and pauses) over seconds."""
    rng = np.random.default_rng(seed)
    n = int(seconds * 16000)
    env = np.repeat(rng.uniform(0, 1, int(seconds * 2) + 1) ** 2, 8000)[:n]
    return (rng.normal(size=n) * env).astype(np.float32)


def test_beat_timing_gain_large_when_motion_follows_the_beats():
    rng = np.random.default_rng(0)
    beats_s = 2.5 + np.cumsum(rng.uniform(0.6, 1.6, 24))                   # irregular, like speech
    beats_s = beats_s[beats_s < 26.0]
    j = joints_with_pauses(list((beats_s * 30).round().astype(int)), T=900)
    bt = beat_timing(j, beats_s)
    assert bt.own > 0.95 and bt.num_shifts > 50
    assert bt.gain > 0.3 and bt.gain > 5 * bt.shifted_std


def test_beat_timing_gain_is_unbiased_for_motion_that_ignores_the_speech():
    """Random pauses, independent of the beats: the mean gain over many draws is ~0."""
    rng = np.random.default_rng(1)
    gains = []
    for _ in range(60):
        beats_s = 2.5 + np.cumsum(rng.uniform(0.6, 1.6, 24))
        beats_s = beats_s[beats_s < 26.0]
        pauses = np.sort(rng.uniform(2.0, 28.0, 20))                     # a stationary process of its own
        j = joints_with_pauses(list((pauses * 30).round().astype(int)), T=900)
        gains.append(beat_timing(j, beats_s, step=0.5).gain)
    assert abs(np.mean(gains)) < 3 * np.std(gains) / np.sqrt(len(gains)) + 1e-3


def test_beat_timing_refuses_clips_too_short_to_shift():
    with pytest.raises(ValueError, match="too short"):
        beat_timing(joints_with_pauses([80], T=150), np.array([2.5]))


def test_loudness_is_rms_per_frame():
    y = np.concatenate([0.5 * np.sin(np.arange(16000) * 2 * np.pi * 440 / 16000), np.zeros(16000)])
    e = loudness(y, 60)
    assert np.allclose(e[2:28], 0.5 / np.sqrt(2), rtol=0.02) and np.all(e[31:] == 0)
    assert len(loudness(y, 70)) == 70 and loudness(y, 70)[-1] == 0      # frames past the end are silent


def test_energy_following_high_when_motion_speed_tracks_loudness():
    y = phrased_noise(40.0, 0)
    T = 1200
    speed = 0.05 + 0.5 * loudness(y, T - 1)
    et = energy_following(joints_with_speed(speed), y)
    assert et.own > 0.9 and et.z > 3 and et.num_shifts > 100


def test_energy_following_is_unbiased_for_motion_that_ignores_the_speech():
    gains = []
    for seed in range(30):
        y, other = phrased_noise(40.0, 2 * seed), phrased_noise(40.0, 2 * seed + 1)
        speed = 0.05 + 0.5 * loudness(other, 1199)                        # follows a different speech
        gains.append(energy_following(joints_with_speed(speed), y, step=0.5).gain)
    assert abs(np.mean(gains)) < 3 * np.std(gains) / np.sqrt(len(gains)) + 1e-3


def test_energy_following_refuses_too_short_clips():
    with pytest.raises(ValueError, match="too short"):
        energy_following(joints_with_speed(np.ones(100)), phrased_noise(3.5, 0))
