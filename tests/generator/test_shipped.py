"""The shipped generators on real held-out speech: the motion they make must look like the speaker's in speed
and smoothness (the release before the data parametrisation was ~8x ground truth's acceleration: jitter)."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.pipeline import ASSETS


@pytest.fixture(scope="module")
def heldout(beat2_root):
    if not (ASSETS / "generator" / "gesturelsm.safetensors").exists():
        pytest.skip(f"shipped generator checkpoints not found in {ASSETS / 'generator'}")
    from gesturelsm.align.words import Word
    from gesturelsm.body import load_body_model
    from gesturelsm.data.beat2 import Beat2Dataset
    from gesturelsm.pipeline import GesturePipeline

    take = Beat2Dataset(beat2_root).load("2_scott_0_1_1")
    cut = int(round(0.8 * take.motion.num_frames)) // 4 * 4       # the split the models were trained with
    t0 = cut / 30
    words = [Word(w.text, w.start - t0, w.end - t0) for w in take.words if w.end > t0]
    pipe = GesturePipeline.from_pretrained(methods=["gesturelsm", "rectified_flow"])
    body = load_body_model()
    speech = pipe.prepare_speech(take.audio[int(round(cut * 16000 / 30)):], 16000, words=words)
    gt = body.joints(take.motion.poses[cut:], take.motion.trans[cut:])
    return pipe, body, speech, gt


def upper_speed_and_acc(j: np.ndarray) -> tuple[float, float]:
    from gesturelsm.motion.regions import REGIONS

    up = list(REGIONS["upper"].joints)
    speed = np.linalg.norm(np.diff(j, axis=0), axis=-1)[:, up].mean() * 30                     # m/s
    acc = np.linalg.norm(j[2:] - 2 * j[1:-1] + j[:-2], axis=-1)[:, up].mean() * 900           # m/s^2
    return float(speed), float(acc)


@pytest.mark.parametrize("method", ["gesturelsm", "rectified_flow"])
def test_shipped_flow_models_move_like_the_speaker_without_jitter(heldout, method):
    pipe, body, speech, gt = heldout
    gt_speed, gt_acc = upper_speed_and_acc(gt)                     # 0.20 m/s, 1.31 m/s^2
    res = pipe.generate(speech, steps=8, cfg=2.0, seed=0, method=method)
    speed, acc = upper_speed_and_acc(body.joints(res.motion.poses, res.motion.trans))
    assert 0.5 * gt_speed < speed < 2.5 * gt_speed, (speed, gt_speed)     # neither static nor frantic
    assert acc < 3.0 * gt_acc, (acc, gt_acc)                               # smooth (old release: ~8x)
