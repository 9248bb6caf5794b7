"""Edits of the real BEAT2 take's own motion with the shipped models and its speech: the edited region changes
clearly inside its range, is the input's outside it, crosses over at the range's ends no faster than the motion
itself moves, and a keyframe's pose is reached, by the latents held for it alone within 10 degrees per joint."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.motion.merge import joint_angles, joint_speeds
from gesturelsm.motion.regions import REGIONS

SECONDS = 20
A, B = 8.0, 11.0                 # the edited range
KEY_TIME, KEY_FRAME = 9.5, 1400  # a keyframe inside it, posed as the take's frame 1400 (46.7 s)


@pytest.fixture(scope="module")
def real(beat2_root):
    from gesturelsm.audio import load_audio
    from gesturelsm.motion import MotionSequence
    from gesturelsm.pipeline import ASSETS, GesturePipeline

    if not (ASSETS / "generator" / "gesturelsm.safetensors").exists():
        pytest.skip(f"shipped generator checkpoints not found in {ASSETS / 'generator'}")
    take = MotionSequence.load(beat2_root / "smplxflame_30" / "2_scott_0_1_1.npz")
    audio = load_audio(beat2_root / "wave16k" / "2_scott_0_1_1.wav")[:16000 * SECONDS]
    pipe = GesturePipeline.from_pretrained(methods=["gesturelsm", "rectified_flow"], warm_up=False)
    speech = pipe.prepare_speech(audio, 16000, transcribe=False)
    return pipe, speech, take.slice(0, 30 * SECONDS), take


def _joints(poses, region):
    return poses.reshape(len(poses), 55, 3)[:, list(REGIONS[region].joints)]


@pytest.mark.parametrize("method", ["gesturelsm", "rectified_flow"])
def test_an_edit_changes_its_range_only_and_crosses_over_without_a_jump(real, method):
    pipe, speech, motion, _ = real
    out = pipe.edit(motion, speech, {"upper": [(A, B)], "hands": [(A, B)]}, method=method, seed=1).motion
    a0, b0 = round(A * 30), round(B * 30)
    for region in ("upper", "hands"):
        x, y = _joints(motion.poses, region), _joints(out.poses, region)
        angle = joint_angles(x, y)
        assert np.degrees(angle[a0:b0].mean()) > 2.0, (region, np.degrees(angle[a0:b0].mean()))
        assert angle[:a0 - 15].max() <= 1e-3 and angle[b0 + 15:].max() <= 1e-3
        own, new = joint_speeds(x), joint_speeds(y)
        p99 = np.percentile(own, 99)
        for end in (a0, b0):
            seam = slice(end - 3, end + 3)
            assert (new[seam] <= np.maximum(p99, own[seam]) + 1e-6).all(), (region, end, new[seam].max(), p99)
    for region in ("lower", "face"):
        assert np.array_equal(_joints(out.poses, region), _joints(motion.poses, region))
    assert np.array_equal(out.trans, motion.trans) and np.array_equal(out.expressions, motion.expressions)


def test_a_keyframe_is_reached_by_the_held_latents_and_exactly_after_pinning(real):
    from gesturelsm.motion.editing import edit_spec, keyframe
    from gesturelsm.motion.merge import merge_edit, splice
    from gesturelsm.motion.postprocess import postprocess

    pipe, speech, motion, take = real
    key = keyframe(KEY_TIME, (take, KEY_FRAME))
    f = key.frame
    up = list(REGIONS["upper"].joints)
    before = np.degrees(joint_angles(_joints(motion.poses, "upper")[f:f + 1], key.pose.reshape(1, 55, 3)[:, up]))
    assert before.max() > 30                                                   # the take is elsewhere then
    spec = edit_spec({"upper": [(A, B)], "hands": [(A, B)]}, motion.num_frames, [key])
    raw = pipe.backends["gesturelsm"].edit(speech, motion, spec, 8, 2.0, 1)
    held_only = merge_edit(motion, postprocess(splice(motion, raw.motion, raw.start, spec.regions), False, "light"),
                           spec)
    got = np.degrees(joint_angles(_joints(held_only.poses, "upper")[f:f + 1], key.pose.reshape(1, 55, 3)[:, up]))
    assert got.max() < 10, got.round(1)
    final = pipe.edit(motion, speech, {"upper": [(A, B)], "hands": [(A, B)]}, keyframes=[(KEY_TIME, (take, KEY_FRAME))],
                      seed=1).motion
    assert np.degrees(joint_angles(_joints(final.poses, "upper")[f:f + 1],
                                   key.pose.reshape(1, 55, 3)[:, up])).max() < 1e-3
