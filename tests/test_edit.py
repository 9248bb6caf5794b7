"""GesturePipeline.edit on tiny checkpoints: what is kept is the input's bits, what is regenerated differs and depends
on the seed only, keyframes are reached, edits chain, the sampler holds the known latents and samples only the
windows an edit touches, and bad input is one clear message."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from gesturelsm.errors import InputError
from gesturelsm.motion.editing import EditError
from gesturelsm.motion.merge import joint_angles
from gesturelsm.motion.regions import REGIONS
from gesturelsm.settings import PostProcess
from _support import speech_like

SECONDS = 8.0


@pytest.fixture(scope="module")
def take(tiny_pipeline):
    """Speech prepared once, and the motion a generation made of it (the motion a user edits)."""
    speech = tiny_pipeline.prepare_speech(speech_like(SECONDS), 16000, transcribe=False)
    return speech, tiny_pipeline.generate(speech, steps=2, seed=0, output="raw").motion


def _joints(motion, region):
    return motion.poses.reshape(motion.num_frames, 55, 3)[:, list(REGIONS[region].joints)]


def test_untouched_regions_are_bit_identical_and_the_edited_one_differs_only_in_its_range(tiny_pipeline, take):
    speech, motion = take
    res = tiny_pipeline.edit(motion, speech, {"upper": [(3.0, 5.0)]}, steps=2, seed=7)
    out = res.motion
    assert out.num_frames == motion.num_frames and res.method == "gesturelsm" and res.seed == 7
    for region in ("hands", "lower", "face", "eyes"):
        assert np.array_equal(_joints(out, region), _joints(motion, region)), region
    assert np.array_equal(out.trans, motion.trans) and np.array_equal(out.expressions, motion.expressions)
    assert np.array_equal(out.betas, motion.betas)
    a, b = _joints(motion, "upper"), _joints(out, "upper")
    assert np.array_equal(a[:90], b[:90]) and np.array_equal(a[150:], b[150:])    # outside the range: the input's
    assert not np.array_equal(a[90:150], b[90:150])          # regenerated (by how much: the shipped model's test)


def test_a_fixed_seed_reproduces_an_edit_and_another_seed_does_not(tiny_pipeline, take):
    speech, motion = take
    ask = {"hands": [(1.0, 2.5)], "face": [(4.0, 6.0)]}
    a = tiny_pipeline.edit(motion, speech, ask, steps=2, seed=3).motion
    b = tiny_pipeline.edit(motion, speech, ask, steps=2, seed=3).motion
    c = tiny_pipeline.edit(motion, speech, ask, steps=2, seed=4).motion
    assert np.array_equal(a.poses, b.poses) and np.array_equal(a.expressions, b.expressions)
    assert not np.array_equal(a.poses, c.poses)
    assert np.array_equal(a.trans, motion.trans)                             # lower kept: its translation too


def test_a_keyframe_is_reached(tiny_pipeline, take):
    speech, motion = take
    pose = np.random.default_rng(5).normal(scale=0.4, size=165).astype(np.float32)
    out = tiny_pipeline.edit(motion, speech, {"upper": [(2.0, 6.0)], "hands": [(2.0, 6.0)]},
                             keyframes=[(4.0, pose)], steps=2, seed=1).motion
    key = pose.reshape(1, 55, 3)
    for region in ("upper", "hands"):
        j = list(REGIONS[region].joints)
        assert np.degrees(joint_angles(out.poses.reshape(-1, 55, 3)[120:121, j], key[:, j])).max() < 10
    assert np.array_equal(_joints(out, "lower"), _joints(motion, "lower"))


def test_edits_chain_and_each_keeps_what_the_one_before_made(tiny_pipeline, take):
    speech, motion = take
    first = tiny_pipeline.edit(motion, speech, {"upper": [(1.0, 3.0)]}, steps=2, seed=1).motion
    second = tiny_pipeline.edit(first, speech, {"lower": [(4.0, 7.0)]}, steps=2, seed=2).motion
    assert np.array_equal(_joints(second, "upper"), _joints(first, "upper"))
    assert not np.array_equal(_joints(second, "upper"), _joints(motion, "upper"))
    assert not np.array_equal(second.trans, first.trans)


def test_only_the_windows_an_edit_touches_are_sampled(tiny_pipeline):
    """An edit of 1 s in the middle of 30 s samples the windows with a latent of that second (2 steps, one batched
    guided call each), where generating samples them all."""
    from gesturelsm.flows import window_layout

    speech = tiny_pipeline.prepare_speech(speech_like(30.0), 16000, transcribe=False)
    motion = tiny_pipeline.generate(speech, steps=2, seed=0, output="raw").motion
    gen = tiny_pipeline.generators["gesturelsm"]
    t, s = gen.config.window_latents, gen.config.seed_latents
    starts = window_layout(225, t, s)
    touched = [st for st in starts if st < 15 * 30 // 4 + 1 and st + t > 14 * 30 // 4 - 1]   # latents 104..113
    den = gen.denoiser
    calls = []
    hook = den.register_forward_hook(lambda *_: calls.append(1))
    try:
        tiny_pipeline.generate(speech, steps=2, seed=0, output="raw")
        generating, calls[:] = len(calls), []
        tiny_pipeline.edit(motion, speech, {"upper": [(14.0, 15.0)]}, steps=2, seed=1)
    finally:
        hook.remove()
    assert generating == 2 * len(starts) and len(calls) == 2 * len(touched) < generating / 4


def test_the_speech_may_differ_from_the_motion_by_a_second_at_most(tiny_pipeline, take):
    speech, motion = take
    y = speech.audio
    longer = np.concatenate([y, y[:8000]])                                   # 0.5 s more: its end is left out
    res = tiny_pipeline.edit(motion, longer, {"upper": [(1.0, 2.0)]}, steps=2, transcribe=False)
    assert res.motion.num_frames == motion.num_frames
    assert any("0.50 s longer than the motion" in w for w in res.warnings)
    with pytest.raises(EditError, match=r"the motion is 8.00 s long but the speech 6.00 s: give the speech the motion "
                                        r"was made from \(they may differ by up to 1 s\)"):
        tiny_pipeline.edit(motion, y[:16000 * 6], {"upper": [(1.0, 2.0)]}, transcribe=False)
    with pytest.raises(EditError, match="the motion is at 60 fps; an edit needs a 30 fps motion"):
        tiny_pipeline.edit(replace(motion, fps=60), speech, {"upper": [(1.0, 2.0)]})
    other = tiny_pipeline.prepare_speech(speech_like(5.0), 16000, transcribe=False)
    with pytest.raises(EditError, match="the motion is 8.00 s long but the speech 5.00 s"):
        tiny_pipeline.edit(motion, other, {"upper": [(1.0, 2.0)]})


@pytest.mark.parametrize("kwargs, message", [
    (dict(regenerate={"upper": [(7.0, 9.0)]}), "lies outside the speech (0-8.00 s)"),
    (dict(regenerate={"torso": [(1.0, 2.0)]}), "unknown region 'torso'"),
    (dict(regenerate={"upper": [(1.0, 2.0)]}, steps=0), "Steps for GestureLSM must be from 1 to 128 (got 0)"),
    (dict(regenerate={"upper": [(1.0, 2.0)]}, method="nope"), "unknown method 'nope'"),
    (dict(regenerate={"upper": [(1.0, 2.0)]}, keyframes=[(1.8, np.zeros(165))]), "needs the upper body"),
    (dict(regenerate={"upper": [(1.0, 3.0)]}, keyframes=[(2.0, "missing.npz:3")]), "missing.npz: file not found"),
    (dict(regenerate={"upper": [(1.0, 2.0)]}, post=PostProcess(smoothing="lots")), "Smoothing must be one of"),
])
def test_bad_edits_are_one_clear_message(tiny_pipeline, take, kwargs, message):
    speech, motion = take
    with pytest.raises(InputError) as err:
        tiny_pipeline.edit(motion, speech, **kwargs)
    assert message in str(err.value)


def test_a_regenerated_lower_body_is_grounded_as_a_generation_is(tiny_pipeline, take):
    """The post-processing runs on the regenerated motion (feet on the ground when the lower body is regenerated); what
    is kept stays the input's either way."""
    speech, motion = take
    on = tiny_pipeline.edit(motion, speech, {"lower": [(2.0, 6.0)]}, steps=2, seed=3,
                            post=PostProcess(grounding=True)).motion
    off = tiny_pipeline.edit(motion, speech, {"lower": [(2.0, 6.0)]}, steps=2, seed=3,
                             post=PostProcess(grounding=False)).motion
    for out in (on, off):
        assert np.array_equal(out.trans[:60], motion.trans[:60]) and np.array_equal(out.trans[180:], motion.trans[180:])
        assert np.array_equal(_joints(out, "upper"), _joints(motion, "upper"))
    assert not np.array_equal(_joints(on, "lower")[60:180], _joints(off, "lower")[60:180])


def test_an_edit_takes_the_settings_object_as_generate_does(tiny_pipeline, take, tmp_path):
    """`settings=Settings(...)` gives the same motion file, byte for byte, as the same settings as keywords."""
    from gesturelsm.settings import Settings

    speech, motion = take
    ask, post = {"upper": [(3.0, 5.0)], "lower": [(1.0, 2.5)]}, PostProcess(stand_in_place=True, smoothing="strong")
    by_keywords = tiny_pipeline.edit(motion, speech, ask, method="gesturelsm", steps=2, cfg=1.5, seed=5, post=post)
    by_settings = tiny_pipeline.edit(motion, speech, ask, settings=Settings(methods=("gesturelsm",),
                                                                            steps={"gesturelsm": 2}, cfg=1.5, seed=5,
                                                                            post=post))
    paths = [r.motion.save(tmp_path / f"{name}.npz") for name, r in (("kw", by_keywords), ("st", by_settings))]
    assert paths[0].read_bytes() == paths[1].read_bytes()
    assert (by_settings.steps, by_settings.cfg, by_settings.seed) == (2, 1.5, 5)


@pytest.mark.parametrize("settings, message", [
    (dict(seed=1.5), "Seed must be a whole number from 0 to 4294967295 (got 1.5; it is not rounded for you)."),
    (dict(seed=2 ** 40), "Seed must be from 0 to 4294967295 (got 1099511627776)."),
    (dict(methods=("nope",)), "Unknown method 'nope'"),
    (dict(post=PostProcess(smoothing="lots")), "Smoothing must be one of"),
])
def test_an_edits_settings_object_goes_through_the_one_validator(tiny_pipeline, take, settings, message):
    """The settings object of an edit is refused as the page's and the command line's values are, each problem with
    the validator's line (the same words as `settings.checked` gives)."""
    from gesturelsm.settings import Asked, Settings, checked
    from gesturelsm.settings.check import asked_of

    speech, motion = take
    with pytest.raises(InputError) as err:
        tiny_pipeline.edit(motion, speech, {"upper": [(1.0, 2.0)]}, settings=Settings(**settings))
    assert message in str(err.value)
    with pytest.raises(InputError) as same:
        checked(asked_of(Settings(**settings)), tiny_pipeline.methods)
    assert str(same.value) == str(err.value) and isinstance(asked_of(Settings()), Asked)
