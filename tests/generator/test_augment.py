"""Speech augmentation for generator training (`gesturelsm train --augment`): off by default with the training
tensors and batches exactly those of training without it; a tempo variant scales audio and motion by the same factor and
keeps speech events on their gestures; pitch and gain variants change the speech features and not the motion."""
from __future__ import annotations

import argparse

import numpy as np
import pytest
import torch
from _support import synthetic_motion

from gesturelsm.errors import UserError
from gesturelsm.generator.augment import Variant, apply_variant, augmented_takes, variants_for, warp_motion
from gesturelsm.generator.data import LatentWindowSampler, build_take, samples_for
from gesturelsm.motion import REGIONS, MotionSequence, Normalizer
from gesturelsm.motion.regions import GENERATED_REGIONS
from gesturelsm.motion.rotations import axis_angle_to_matrix, geodesic_angle
from gesturelsm.tokenizer import RVQVAE, preset

PEAKS = (60, 150, 240)        # frames of the gesture strokes and the loud syllables
JOINT = 18                    # left elbow


def _tokenizers(feats: torch.Tensor) -> dict[str, RVQVAE]:
    torch.manual_seed(0)
    return {r: RVQVAE(preset("tiny", len(REGIONS[r].columns)), r,
                      Normalizer.fit(feats[:, list(REGIONS[r].columns)])).eval() for r in GENERATED_REGIONS}


def _bursty_clip(T: int = 300) -> tuple[MotionSequence, np.ndarray]:
    """Elbow strokes (bumps of the joint angle) and noise bursts at the same instants PEAKS, silence between."""
    t = np.arange(T)
    poses = np.zeros((T, 165), np.float32)
    poses[:, 3 * JOINT] = sum(1.2 * np.exp(-((t - p) ** 2) / (2 * 4.0 ** 2)) for p in PEAKS)
    motion = MotionSequence(poses, np.tile([0.0, 1.3, 0.0], (T, 1)), np.zeros((T, 100)))
    n = samples_for(T)
    ts = np.arange(n) / 16000
    env = sum(np.exp(-((ts - p / 30) ** 2) / (2 * 0.04 ** 2)) for p in PEAKS)
    y = 0.5 * env * np.random.default_rng(0).standard_normal(n)
    return motion, y.astype(np.float32)


def _frame_loudness(y: np.ndarray, T: int) -> np.ndarray:
    return np.array([np.sqrt(np.mean(y[samples_for(j):samples_for(j + 1)] ** 2)) for j in range(T)])


def _peak_near(x: np.ndarray, centre: float, half: int = 20) -> int:
    lo = max(0, int(round(centre)) - half)
    return lo + int(np.argmax(x[lo:int(round(centre)) + half + 1]))


@pytest.mark.parametrize("rate", [0.9, 1.1])
def test_tempo_variant_scales_audio_and_motion_alike_and_keeps_them_aligned(rate):
    motion, y = _bursty_clip()
    m2, y2, words = apply_variant(Variant("tempo", rate), motion, y, None)
    T, T2 = motion.num_frames, m2.num_frames
    assert T2 == round(T / rate) and len(y2) == samples_for(T2)      # both last 1 / rate as long, same length
    stroke = m2.poses[:, 3 * JOINT]
    loud = _frame_loudness(y2, T2)
    for p in PEAKS:
        want = p / rate
        assert abs(_peak_near(stroke, want) - want) <= 1.0, (p, _peak_near(stroke, want), want)
        assert abs(_peak_near(loud, want) - want) <= 1.5, (p, _peak_near(loud, want), want)


def test_tempo_variant_rescales_word_times():
    from gesturelsm.align.words import Word

    motion, y = _bursty_clip()
    _, _, words = apply_variant(Variant("tempo", 1.1), motion, y, [Word("hi", 1.1, 2.2)])
    assert words[0].start == pytest.approx(1.0) and words[0].end == pytest.approx(2.0)


def test_warp_motion_samples_the_original_poses():
    """rate 2: frame j is the original frame 2j; rate 0.5: odd frames lie halfway (geodesically) between two
    original frames; rate 1: the clip itself."""
    m = synthetic_motion(61)
    R = axis_angle_to_matrix(torch.from_numpy(m.poses).reshape(61, -1, 3))
    fast = axis_angle_to_matrix(torch.from_numpy(warp_motion(m, 2.0).poses).reshape(-1, 55, 3))
    assert fast.shape[0] == 30 or fast.shape[0] == 31
    assert float(geodesic_angle(fast, R[0:2 * fast.shape[0]:2]).max()) < 1e-3
    slow = axis_angle_to_matrix(torch.from_numpy(warp_motion(m, 0.5).poses).reshape(-1, 55, 3))
    a, b = geodesic_angle(slow[1:41:2], R[0:20]), geodesic_angle(slow[1:41:2], R[1:21])
    assert float((a - b).abs().max()) < 1e-3 * float(geodesic_angle(R[0:20], R[1:21]).max()) + 1e-4
    assert float(geodesic_angle(slow[0:40:2], R[0:20]).max()) < 1e-3
    same = warp_motion(m, 1.0)
    assert np.allclose(same.to_features().numpy(), m.to_features().numpy(), atol=1e-5)


def test_pitch_and_gain_variants_keep_the_motion_and_change_the_speech_features():
    motion, y = _bursty_clip()
    feats = motion.to_features()
    toks = _tokenizers(synthetic_motion(320).to_features())
    orig = build_take("c", feats, y, None, toks, None)
    pitch, pitch_mirror, gain, _ = augmented_takes("c", motion, y, None, toks, None,
                                                   [Variant("pitch", 2.0), Variant("gain", 6.0)])
    assert pitch.name == "c~pitch+2" and gain.name == "c~gain+6"
    assert torch.equal(pitch.latents, orig.latents) and torch.equal(gain.latents, orig.latents)
    assert torch.equal(pitch_mirror.latents, build_take("c", feats, y, None, toks, None, mirror=True).latents)
    assert pitch.audio.shape == orig.audio.shape == gain.audio.shape
    change = (pitch.audio[0] - orig.audio[0]).abs().mean() / orig.audio[0].abs().mean()
    assert change > 0.02                                               # the envelope of other-pitched speech
    torch.testing.assert_close(gain.audio[0], orig.audio[0] * 10 ** (6 / 20), rtol=1e-5, atol=0)


def test_variants_are_named_and_checked():
    assert variants_for(None) == [] and variants_for([]) == []
    assert [v.name for v in variants_for(["gain", "tempo"])] == ["tempo0.9", "tempo1.1", "gain-6", "gain+6"]
    with pytest.raises(UserError, match="unknown kind"):
        variants_for(["speed"])
    from gesturelsm.commands.train import add_parser

    p = argparse.ArgumentParser()
    add_parser(p.add_subparsers())
    assert p.parse_args(["train", "--data", "x"]).augment == []
    assert p.parse_args(["train", "--data", "x", "--augment", "tempo", "pitch"]).augment == ["tempo", "pitch"]


def test_default_off_keeps_the_training_takes_and_batches_bit_identical(tmp_path, beat2_maker):
    """Without --augment the training list is [take, mirror] of the first 80 %, exactly what `build_take` gives
    (the recipe before augmentation existed), so the sampler draws the same batches; with it the same two come
    first and two per variant follow."""
    from gesturelsm.data.beat2 import Beat2Dataset
    from gesturelsm.commands.train import training_takes

    seq = beat2_maker(tmp_path, "2_scott_0_1_1", 300)
    ds = Beat2Dataset(tmp_path)
    toks = _tokenizers(seq.to_features())
    train, held = training_takes(ds, toks, None, 0.8)
    take = ds.load("2_scott_0_1_1")
    feats, a = take.motion.to_features()[:240], take.audio[:samples_for(240)]
    before = [build_take("2_scott_0_1_1", feats, a, take.words, toks, None, mirror=mr) for mr in (False, True)]
    assert [t.name for t in train] == [t.name for t in before] and len(held) == 1

    def batch(takes):
        s = LatentWindowSampler(takes, 8, 2, torch.ones(len(toks)), torch.zeros(len(toks), 2, 16), 0.1, 0.2, seed=3,
                                seed_noise=0.5)
        return s.sample(8)

    got, want = batch(train), batch(before)
    for f in ("x1", "seed", "audio", "words", "has_word", "has_text"):
        assert torch.equal(getattr(got, f), getattr(want, f)), f
    aug, held_aug = training_takes(ds, toks, None, 0.8, variants_for(["tempo"]))
    assert len(aug) == 6 and all(torch.equal(x.latents, y.latents) and torch.equal(x.audio, y.audio)
                                 for x, y in zip(aug[:2], train))
    assert [t.latents.shape[1] for t in aug[2:]] == [66, 66, 54, 54]   # 240 frames / 0.9 = 267, / 1.1 = 218, // 4
    assert torch.equal(held_aug[0].latents, held[0].latents)
