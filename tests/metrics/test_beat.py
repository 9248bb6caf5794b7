import numpy as np

from _support import joints_with_pauses

from gesturelsm.metrics.beat import beat_consistency, beat_score, motion_beats


def test_beats_on_audio_onsets_score_near_one_and_drop_when_shifted():
    beats_s = np.arange(3.0, 17.0, 0.9)
    frames = list((beats_s * 30).round().astype(int))
    on = beat_consistency(joints_with_pauses(frames), beats=beats_s)
    off = beat_consistency(joints_with_pauses([f + 12 for f in frames]), beats=beats_s)   # 0.4 s late
    assert on > 0.95
    assert off < 0.6 and off < on - 0.3


def test_rest_minima_and_edges_are_not_beats():
    speed = np.ones(300)
    speed[150] = 0.1            # a stop (below 0.3 of mean speed): not a beat
    speed[30] = 0.5             # inside the first 60 frames: ignored
    speed[200] = 0.5            # a dip while moving: a beat
    assert list(motion_beats(speed)) == [200 / 30]


def test_score_formula():
    assert abs(beat_score(np.array([1.0]), np.array([1.3])) - np.exp(-0.09 / 0.18)) < 1e-12
    assert beat_score(np.array([1.0, 2.0]), np.array([])) == 0.0


def click_track(times_s: np.ndarray, seconds: float, sr: int = 16000) -> np.ndarray:
    """Silence with short decaying noise bursts at the given times: onsets librosa finds reliably."""
    rng = np.random.default_rng(0)
    y = np.zeros(int(seconds * sr), np.float32)
    burst = (rng.normal(size=800) * np.exp(-np.arange(800) / 150)).astype(np.float32)
    for t in times_s:
        i = int(t * sr)
        y[i:i + 800] += 0.5 * burst
    return y


def test_bc_from_audio_onsets_near_one_on_beat_and_drops_when_shifted():
    """End to end through librosa: motion pausing on the audio's onsets vs the same motion 0.4 s late."""
    beats_s = np.arange(3.0, 17.0, 0.9)
    audio = click_track(beats_s, 20.0)
    frames = list((beats_s * 30).round().astype(int))
    on = beat_consistency(joints_with_pauses(frames), audio)
    off = beat_consistency(joints_with_pauses([f + 12 for f in frames]), audio)
    assert on > 0.9
    assert off < on - 0.3


def test_bc_normalised_by_given_mean_speed_is_scale_free():
    """Dividing by the per-joint mean speed makes BC independent of the motion's overall speed."""
    beats_s = np.arange(3.0, 17.0, 0.9)
    j = joints_with_pauses(list((beats_s * 30).round().astype(int)))
    ms = np.linalg.norm(np.diff(j, axis=0), axis=-1).mean(0) * 30
    a = beat_consistency(j, beats=beats_s, mean_speed=ms)
    assert a == beat_consistency(3 * j, beats=beats_s, mean_speed=3 * ms) > 0.95
