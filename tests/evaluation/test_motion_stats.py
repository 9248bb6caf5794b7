"""Per-motion statistics (evaluation/motion_stats.py): the same numbers as `gesturelsm eval`'s definitions, the seed
spread's invariants, and the speaker's stored reference row against a value computed here from ../shared."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from _support import BEAT2, speech_like, synthetic_motion
from gesturelsm.evaluation.evaluate import motion_stats as eval_motion_stats
from gesturelsm.evaluation.motion_stats import (SPEAKER_FILE, STATISTICS, SpeechContext, joint_positions,
                                                motion_statistics, seed_spread, speaker_reference,
                                                statistics_of_joints, stats_body)
from gesturelsm.metrics.speech_response import beat_timing, energy_following



def test_statistics_equal_the_eval_definitions_for_the_same_motion():
    motion = synthetic_motion(frames=300, seed=4)
    audio = speech_like(10.0, seed=2)
    mean_speed = np.linspace(0.2, 0.6, 55)
    speech = SpeechContext.of(audio, mean_speed)
    got = motion_statistics(motion, stats_body(), speech)
    assert list(got) == [s.key for s in STATISTICS]
    want = eval_motion_stats(motion, stats_body(), speech.beats, mean_speed, extractors=[])
    assert np.isfinite(want.bc) and got["bc"] == pytest.approx(want.bc, rel=1e-9)
    assert got["diversity"] == pytest.approx(want.diversity, rel=1e-5)       # eval: FK with zero translation
    for k in ("raised_share", "height_p95", "wrist_speed", "hand_spread", "jerk"):
        assert got[k] == pytest.approx(want.amplitude[k], rel=1e-9), k
    world = stats_body().joints(motion.poses, motion.trans)
    assert got["beat_gain"] == pytest.approx(beat_timing(world, speech.beats, mean_speed=mean_speed).gain)
    assert got["loudness_gain"] == pytest.approx(energy_following(world, audio).gain)


def test_statistics_of_a_motion_too_short_for_the_shift_tests_are_nan_not_an_error():
    motion = synthetic_motion(frames=45, seed=1)
    got = motion_statistics(motion, stats_body(), SpeechContext.of(speech_like(1.5)))
    assert np.isnan(got["beat_gain"]) and np.isnan(got["loudness_gain"])
    assert np.isfinite(got["wrist_speed"]) and np.isfinite(got["diversity"])


def test_seed_spread_is_zero_for_equal_motions_and_the_l1_offset_for_shifted_ones():
    _, a = joint_positions(synthetic_motion(frames=60, seed=1))
    assert seed_spread([a]) != seed_spread([a])                             # NaN: one seed has no spread
    assert seed_spread([a, a.copy()]) == 0.0
    offset = np.array([0.1, -0.2, 0.05])
    assert seed_spread([a, a + offset, a]) == pytest.approx(2 / 3 * 55 * np.abs(offset).sum())


def _load_take(name: str):
    import soundfile as sf

    from gesturelsm.audio import resample, to_mono
    from gesturelsm.motion import MotionSequence

    motion = MotionSequence.load(BEAT2 / "smplxflame_30" / f"{name}.npz")
    y, sr = sf.read(BEAT2 / "wave16k" / f"{name}.wav", dtype="float32")
    return motion, resample(to_mono(y), sr, 16000)


def test_the_stored_speaker_row_matches_the_training_take_measured_here():
    if not (BEAT2 / "smplxflame_30").is_dir():
        pytest.skip(f"{BEAT2} is absent (the real BEAT2 take lives in ../shared)")
    takes = sorted(p.stem for p in (BEAT2 / "smplxflame_30").glob("*.npz"))
    stored = json.loads(SPEAKER_FILE.read_text())
    ref = speaker_reference()
    assert set(stored["statistics"]) == {s.key for s in STATISTICS}
    assert all(t in stored["source"] for t in takes)
    frames, raised, speed, spread, heights = 0, 0.0, 0.0, 0.0, []
    for name in takes:
        motion, _ = _load_take(name)
        j = stats_body().joints(motion.poses, motion.trans).astype(np.float64)
        rel = j[:, 20:22] - j[:, :1]                                    # wrists (20, 21) from the pelvis (0)
        h = rel[..., 1].max(1)
        heights.append(h)
        raised += (h > 0.25).sum()
        speed += np.sqrt((np.diff(rel, axis=0) ** 2).sum(-1)).mean() * 30 * len(j)
        spread += np.sqrt(((j[:, 20] - j[:, 21]) ** 2).sum(-1)).mean() * len(j)
        frames += len(j)
    st = ref.statistics
    assert st["raised_share"] == pytest.approx(raised / frames, abs=1e-5)
    assert st["wrist_speed"] == pytest.approx(speed / frames, rel=1e-4)
    assert st["hand_spread"] == pytest.approx(spread / frames, rel=1e-4)
    if len(takes) == 1:
        assert st["height_p95"] == pytest.approx(np.percentile(heights[0], 95), rel=1e-4)
        assert ref.seconds == pytest.approx(frames / 30, abs=0.01)


def test_the_speaker_row_is_what_the_statistics_give_for_the_take_against_its_own_speech():
    if not (BEAT2 / "smplxflame_30").is_dir():
        pytest.skip(f"{BEAT2} is absent (the real BEAT2 take lives in ../shared)")
    takes = sorted(p.stem for p in (BEAT2 / "smplxflame_30").glob("*.npz"))
    if len(takes) != 1:
        pytest.skip("several takes: the row is a weighted mean (checked above for the amplitude statistics)")
    motion, audio = _load_take(takes[0])
    world, local = joint_positions(motion)
    n = min(len(world), len(audio) * 30 // 16000)
    ref = speaker_reference()
    got = statistics_of_joints(world[:n], local[:n], SpeechContext.of(audio[: n * 16000 // 30], ref.mean_speed))
    for k in ("bc", "beat_gain", "loudness_gain", "jerk", "diversity"):
        assert got[k] == pytest.approx(ref.statistics[k], rel=1e-3, abs=1e-5), k


def test_the_speech_response_gains_need_the_speech_length_the_docs_and_tooltips_say():
    """The beat timing gain was blank for 6 s of speech while the docs said about 5 s suffice: the shortest speech
    each gain is computed for, found by trying every length, is the length docs/SWEEP.md and the page's tooltips
    give."""
    import math

    from gesturelsm.evaluation.motion_stats import BY_KEY

    motion = synthetic_motion(frames=300, seed=5)
    audio = speech_like(10.0, seed=6)
    world = stats_body().joints(motion.poses, motion.trans)
    beats = SpeechContext.of(audio).beats

    def shortest(test) -> float:
        for frames in range(60, 300):
            try:
                test(frames)
            except ValueError:
                continue
            return math.ceil(frames / 30 * 10 - 1e-9) / 10       # seconds of speech that give that many frames
        raise AssertionError("never computed")

    beat_s = shortest(lambda n: beat_timing(world[:n], beats[beats < n / 30]))
    loud_s = shortest(lambda n: energy_following(world[:n], audio[: n * 16000 // 30]))
    assert (beat_s, loud_s) == (6.1, 4.1)
    docs = " ".join((Path(__file__).resolve().parents[2] / "docs" / "SWEEP.md").read_text().split())
    assert f"the beat timing gain at least {beat_s:g} s, loudness following at least {loud_s:g} s" in docs
    assert f"needs at least {beat_s:g} s of speech" in BY_KEY["beat_gain"].tooltip
    assert f"needs at least {loud_s:g} s of speech" in BY_KEY["loudness_gain"].tooltip
