"""`gesturelsm generate --rig`: the generated motion is also written onto the user's character, and a bad
character file stops the command with one line before any generation."""
from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf
from scipy.spatial.transform import Rotation

from _rigs import build_rig, write_gltf
from _support import speech_like
from gesturelsm.body.model import resolve_body
from gesturelsm.cli import main
from gesturelsm.export.glb import accessor_array, read_glb
from gesturelsm.motion import MotionSequence
from gesturelsm.retarget import load_character, retarget_motion


def test_generate_with_rig_writes_the_motion_on_the_character(tiny_assets, tmp_path, capsys):
    sf.write(tmp_path / "s.wav", speech_like(1.5, seed=4), 16000)
    skel, _ = build_rig(resolve_body(None).rest_joints(), fingers=False)
    write_gltf(skel, tmp_path / "me.glb")
    assert main(["generate", str(tmp_path / "s.wav"), "--checkpoints", str(tiny_assets), "--steps", "1",
                 "--no-transcribe", "--out", str(tmp_path / "take.npz"), "--rig", str(tmp_path / "me.glb")]) == 0
    out = tmp_path / "take_me.glb"
    assert f"wrote {out}" in capsys.readouterr().out
    motion = MotionSequence.load(tmp_path / "take.npz")
    want = retarget_motion(motion, load_character(tmp_path / "me.glb"))
    gltf, blob = read_glb(out)
    anim = gltf["animations"][0]
    ch = next(c for c in anim["channels"] if c["target"]["node"] == skel.bones["left_elbow"])
    got = Rotation.from_quat(accessor_array(gltf, blob, anim["samplers"][ch["sampler"]]["output"])).as_matrix()
    np.testing.assert_allclose(got, want.local_rotation[:, skel.bones["left_elbow"]], atol=1e-5)
    assert len(got) == motion.num_frames == 45


def test_generate_refuses_a_bad_character_before_generating(tmp_path, capsys):
    sf.write(tmp_path / "s.wav", speech_like(1.0), 16000)
    (tmp_path / "me.vrm").write_bytes(b"\x00" * 64)
    assert main(["generate", str(tmp_path / "s.wav"), "--out", str(tmp_path / "t.npz"), "--rig",
                 str(tmp_path / "me.vrm")]) == 2
    assert "me.vrm: not a glTF / VRM file" in capsys.readouterr().err
    assert not (tmp_path / "t.npz").exists()


def test_generate_says_what_it_does_and_shows_the_recognised_words(tiny_assets, tmp_path, capsys, hears_hello):
    sf.write(tmp_path / "s.wav", speech_like(2.0, seed=2), 16000)
    assert main(["generate", str(tmp_path / "s.wav"), "--checkpoints", str(tiny_assets), "--steps", "1",
                 "--out", str(tmp_path / "take.npz")]) == 0
    out, err = capsys.readouterr()
    assert 'recognised: "hello there"' in out
    said = [line.split("] ", 1)[1] for line in err.splitlines() if line.startswith("[")]
    assert said.index("recognising the words (automatic transcription)") < said.index("speech transcribed")
    assert any(s.startswith("gesturelsm: window 1/") for s in said) and said[-1] == "gesturelsm: done"


def test_generate_reports_the_real_time_factor_with_and_without_transcription(tiny_assets, tmp_path, capsys,
                                                                              hears_hello):
    """The paper's convention (generation only) and end to end (from the models loaded: the rest of the words,
    generation, writing), both; and the share of the transcription hidden: all but what generation waited for."""
    import re

    sf.write(tmp_path / "s.wav", speech_like(3.0, seed=2), 16000)
    assert main(["generate", str(tmp_path / "s.wav"), "--checkpoints", str(tiny_assets), "--steps", "1",
                 "--out", str(tmp_path / "take.npz")]) == 0
    out = capsys.readouterr().out
    line = out.split("\ntimings: ")[1].splitlines()[0]
    stages = {k: float(v) for k, v in (part.rsplit(" ", 1) for part in line.replace("s,", ",").rstrip("s").split(", "))}
    assert set(stages) == {"features", "transcription", "sampling", "decoding", "waiting for words"}
    tr, waited = stages["transcription"], stages["waiting for words"]
    hid = re.search(r"^transcription ([\d.]+) s, ([\d.]+) s of it \((\d+) %\) hidden under loading the models and "
                    r"generation \(.*; generation waited ([\d.]+) s for words\)$", out, re.M)
    assert hid, out                                                  # recognised while generated (pipelined)
    assert float(hid[1]) == pytest.approx(tr, abs=0.006) and float(hid[4]) == pytest.approx(waited, abs=0.006)
    assert float(hid[2]) == pytest.approx(max(0.0, tr - waited), abs=0.011)
    m = re.search(r"real-time factor ([\d.]+)x for generation \(.*?\), ([\d.]+)x end to end \(([\d.]+) s", out)
    gen, whole, seconds = map(float, m.groups())
    assert gen == pytest.approx(3.0 / (stages["features"] + stages["sampling"] + stages["decoding"]), rel=0.1, abs=0.1)
    assert seconds >= stages["sampling"] + stages["decoding"] + waited - 0.05     # the wait for words counted
    assert whole == pytest.approx(3.0 / seconds, rel=0.1, abs=0.1)


def test_generate_out_without_npz_reports_the_file_it_wrote(tiny_assets, tmp_path, capsys):
    sf.write(tmp_path / "s.wav", speech_like(1.0, seed=2), 16000)
    assert main(["generate", str(tmp_path / "s.wav"), "--checkpoints", str(tiny_assets), "--steps", "1",
                 "--no-transcribe", "--out", str(tmp_path / "take")]) == 0
    out = capsys.readouterr().out
    assert f"{tmp_path / 'take.npz'}: 30 frames" in out and (tmp_path / "take.npz").is_file()
    assert not (tmp_path / "take").exists()


def test_a_transcript_far_too_short_for_the_speech_is_warned_about(tiny_assets, tmp_path, capsys):
    from _asr_support import ENGLISH, speak
    from gesturelsm.align import tts

    if not tts.available():
        pytest.skip("eSpeak NG is not installed")
    sf.write(tmp_path / "s.wav", speak(ENGLISH, "en-us"), 16000)
    for text, warned in ((" ".join(ENGLISH.split()[:2]), True), (ENGLISH, False)):
        assert main(["generate", str(tmp_path / "s.wav"), "--checkpoints", str(tiny_assets), "--steps", "1",
                     "--text", text, "--out", str(tmp_path / "take.npz")]) == 0
        out = capsys.readouterr().out
        assert ("warning: The transcript looks far too short for the speech: its 2 words" in out) is warned, out


def test_generate_with_rig_follows_grounding(tiny_assets, tmp_path):
    """--grounding off: the character's file carries its legs as retargeted from the ungrounded motion; on (the
    default) grounded on its own legs (retarget_motion's default), and the two differ."""
    from _standing import other_legs

    sf.write(tmp_path / "s.wav", speech_like(3.0, seed=5), 16000)
    skel, _ = build_rig(other_legs(resolve_body(None).rest_joints()), fingers=False)
    write_gltf(skel, tmp_path / "me.glb")
    roots = {}
    for mode in ("on", "off"):
        out = tmp_path / mode
        assert main(["generate", str(tmp_path / "s.wav"), "--checkpoints", str(tiny_assets), "--steps", "1",
                     "--no-transcribe", "--out", str(out / "take.npz"), "--rig", str(tmp_path / "me.glb"),
                     "--grounding", mode]) == 0
        motion = MotionSequence.load(out / "take.npz")
        want = retarget_motion(motion, load_character(tmp_path / "me.glb"), grounding=mode == "on")
        gltf, blob = read_glb(out / "take_me.glb")
        anim = gltf["animations"][0]
        ch = next(c for c in anim["channels"] if c["target"]["path"] == "translation")
        roots[mode] = accessor_array(gltf, blob, anim["samplers"][ch["sampler"]]["output"])
        np.testing.assert_allclose(roots[mode], want.root_translation, atol=1e-5)
    assert np.abs(roots["on"] - roots["off"]).max() > 1e-3


def _arrays(path) -> dict:
    with np.load(path, allow_pickle=False) as f:
        return {k: f[k] for k in f.files}


@pytest.mark.parametrize("flags, settings", [
    ((), None),                                                          # the README's example: keywords only
    (("--method", "ddim", "--seed", "3", "--cfg", "1.5", "--grounding", "off", "--stand-in-place", "--smoothing",
      "medium"), "settings")])
def test_the_python_call_gives_the_commands_motion_bit_for_bit(tiny_assets, tiny_pipeline, tmp_path, flags,
                                                               settings):
    """`pipe.generate(...)` (as the README shows it, or with one settings object) and `gesturelsm generate` with the
    same settings: the same arrays in the written npz, key for key (the finished motion: fitted, smoothed, grounded,
    with its words); `output="raw"` is the motion before that."""
    from gesturelsm.audio import load_audio
    from gesturelsm.settings import PostProcess, Settings

    wav = tmp_path / "s.wav"
    sf.write(wav, speech_like(2.0, seed=6), 16000)
    assert main(["generate", str(wav), "--checkpoints", str(tiny_assets), "--text", "hello there", "--steps", "2",
                 *flags, "--out", str(tmp_path / "cli.npz")]) == 0
    if settings is None:
        res = tiny_pipeline.generate(load_audio(wav), 16000, text="hello there", steps=2)
    else:
        chosen = Settings(methods=("ddim",), steps={"ddim": 2}, cfg=1.5, seed=3,
                          post=PostProcess(stand_in_place=True, smoothing="medium", grounding=False))
        res = tiny_pipeline.generate(load_audio(wav), 16000, text="hello there", settings=chosen)
    res.motion.save(tmp_path / "py.npz")
    cli, py = _arrays(tmp_path / "cli.npz"), _arrays(tmp_path / "py.npz")
    assert sorted(cli) == sorted(py) and "word_times" in cli
    for k in cli:
        assert np.array_equal(cli[k], py[k]), k
    raw = tiny_pipeline.generate(load_audio(wav), 16000, text="hello there", steps=2, output="raw").motion
    if settings is None:                                                 # grounding and smoothing changed it
        assert not np.array_equal(raw.poses, res.motion.poses)


def test_generate_refuses_an_unknown_output(tiny_pipeline):
    with pytest.raises(ValueError, match="finished, raw"):
        tiny_pipeline.generate(speech_like(1.0), 16000, output="smoothed")


def test_generate_recognises_the_words_while_the_models_load(tiny_assets, tmp_path, capsys, monkeypatch):
    import threading
    from types import SimpleNamespace

    import gesturelsm.pipeline as pipeline
    from gesturelsm.align import Word
    from gesturelsm.asr.source import AutomaticWords

    started, seen = threading.Event(), []

    def hear(audio, remember=True, language="auto", on_piece=None):
        started.set()
        return AutomaticWords([Word("hello", 0.3, 0.7), Word("there", 0.8, 1.3)], "automatic transcript (2 words)",
                              SimpleNamespace(text="hello there"))
    real = pipeline.GesturePipeline.from_pretrained

    def loading(*args, **kwargs):
        seen.append(started.wait(30))
        return real(*args, **kwargs)
    monkeypatch.setattr(pipeline, "automatic_words", hear)
    monkeypatch.setattr(pipeline.GesturePipeline, "from_pretrained", staticmethod(loading))
    sf.write(tmp_path / "s.wav", speech_like(3.0, seed=2), 16000)
    assert main(["generate", str(tmp_path / "s.wav"), "--checkpoints", str(tiny_assets), "--steps", "1",
                 "--out", str(tmp_path / "take.npz")]) == 0
    assert seen == [True]
    assert 'recognised: "hello there"' in capsys.readouterr().out


def test_silent_speech_is_refused_before_the_models_load(tmp_path, capsys):
    sf.write(tmp_path / "s.wav", np.zeros(3 * 16000, np.float32), 16000)
    assert main(["generate", str(tmp_path / "s.wav"), "--out", str(tmp_path / "take.npz")]) == 2
    err = capsys.readouterr().err
    assert "the audio is silent: there is no speech to gesture to" in err and "loading the models" not in err, err
    assert not (tmp_path / "take.npz").exists()
