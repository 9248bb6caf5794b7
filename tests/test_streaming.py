"""`GesturePipeline.stream` (gesturelsm/streaming.py): each method's windows as the sampler makes them final, its
whole raw motion, then the method made; the whole raw motion is `generate(output="raw")` and the method made is
`generate(...)` bit for bit, the windows' new frames add up to the raw motion (to float rounding), and
`generate_each` is the stream's methods without windows. Tiny checkpoints (windows of 32 frames) and the shipped
ones, on short speech."""
from __future__ import annotations

import threading

import numpy as np
import pytest
from _support import speech_like

from gesturelsm.errors import InputError
from gesturelsm.pipeline import Made, Plan, Window
from gesturelsm.settings import PostProcess, Settings

ALL = ("gesturelsm", "rectified_flow", "ddim")
STEPS = {"gesturelsm": 3, "rectified_flow": 1, "ddim": 2}


def _same(a, b) -> None:
    np.testing.assert_array_equal(a.poses, b.poses)
    np.testing.assert_array_equal(a.trans, b.trans)
    np.testing.assert_array_equal(a.expressions, b.expressions)
    assert (a.transcript, a.words) == (b.transcript, b.words)


def _by_method(events) -> dict[str, list]:
    out: dict[str, list] = {}
    for ev in events:
        out.setdefault(ev.method, []).append(ev)
    return out


def _pieces(windows: list[Window]) -> list[np.ndarray]:
    """The new frames of each window (poses), from the frames of the window before."""
    return [w.motion.poses[a:] for a, w in zip([0] + [w.frames for w in windows[:-1]], windows)]


def test_each_method_streams_its_windows_then_equals_generate(tiny_pipeline):
    y = speech_like(8.0)
    settings = Settings(methods=ALL, steps=dict(STEPS), seed=5, post=PostProcess(smoothing="light"), transcribe=False)
    events = list(tiny_pipeline.stream(y, 16000, settings=settings))
    order = [ev.method for ev in events if isinstance(ev, Made)]
    assert order == ["rectified_flow", "ddim", "gesturelsm"]                       # fewest steps first
    for m, evs in _by_method(events).items():
        *windows, made = evs
        assert isinstance(made, Made) and made.error is None and all(isinstance(w, Window) for w in windows)
        assert len(windows) >= 3 and windows[-1].whole and not any(w.whole for w in windows[:-1])
        frames = [w.frames for w in windows]
        assert frames == sorted(set(frames)) and frames[0] > 0                      # growing, from frame 0
        one = replace_methods(settings, m)
        raw = tiny_pipeline.generate(y, 16000, settings=one, output="raw").motion
        _same(windows[-1].motion, raw)                                              # the whole raw motion
        _same(made.motion, tiny_pipeline.generate(y, 16000, settings=one).motion)   # the finished one
        joined = np.concatenate(_pieces(windows))
        assert joined.shape == raw.poses.shape
        np.testing.assert_array_equal(joined[frames[-2]:], raw.poses[frames[-2]:])  # the last window: exact
        np.testing.assert_allclose(joined, raw.poses, rtol=0, atol=1e-4)            # the others: to float rounding
        for w in windows[:-1]:                                  # each window keeps the frames before it as they were
            np.testing.assert_array_equal(w.motion.poses, joined[:w.frames])
        np.testing.assert_allclose(windows[-2].motion.trans, raw.trans[:frames[-2]], rtol=0, atol=1e-5)


def replace_methods(settings: Settings, method: str) -> Settings:
    from dataclasses import replace

    return replace(settings, methods=(method,))


def test_a_method_made_again_on_the_finished_words_streams_its_windows_again(tiny_pipeline):
    """Automatic words, pipelined: tones have no English words, so the method made with the streamed ones is made
    again on the finished speech (pipelined.Restart) and its windows start again from the first."""
    y = speech_like(8.0)
    settings = Settings(methods=("rectified_flow",), steps={"rectified_flow": 1}, seed=4)
    *windows, made = tiny_pipeline.stream(y, 16000, settings=settings)
    frames = [w.frames for w in windows]
    again = max(i for i, f in enumerate(frames) if i == 0 or f < frames[i - 1])
    assert frames[again:] == sorted(set(frames[again:])) and windows[-1].whole
    _same(made.motion, tiny_pipeline.generate(y, 16000, settings=settings).motion)
    _same(windows[-1].motion, tiny_pipeline.generate(y, 16000, settings=settings, output="raw").motion)


def test_raw_output_streams_the_raw_motion_as_made(tiny_pipeline):
    y = speech_like(2.0)
    settings = Settings(methods=("ddim",), steps={"ddim": 2}, seed=1, transcribe=False)
    *windows, made = tiny_pipeline.stream(y, 16000, settings=settings, output="raw")
    assert made.motion is windows[-1].motion
    _same(made.motion, tiny_pipeline.generate(y, 16000, settings=settings, output="raw").motion)


def test_generate_each_is_the_stream_without_windows(tiny_pipeline):
    speech = tiny_pipeline.prepare_speech(speech_like(2.5), transcribe=False)
    plan = Plan(Settings(methods=ALL, steps=dict(STEPS), seed=2))
    each = list(tiny_pipeline.generate_each(speech, plan))
    streamed = [ev for ev in tiny_pipeline.stream(speech, plan=plan) if isinstance(ev, Made)]
    assert [x.method for x in each] == [x.method for x in streamed]
    for a, b in zip(each, streamed):
        _same(a.motion, b.motion)
        assert a.warnings == b.warnings
    assert all(isinstance(x, Made) for x in tiny_pipeline.stream(speech, plan=plan, windows=False))


def test_closing_the_stream_stops_its_thread(tiny_pipeline):
    stream = tiny_pipeline.stream(speech_like(8.0), 16000,
                                  settings=Settings(methods=ALL, steps=dict(STEPS), transcribe=False))
    first = next(stream)
    assert isinstance(first, Window) and first.method == "rectified_flow" and not first.whole
    stream.close()                                                        # waits for the generating thread
    assert not [t for t in threading.enumerate() if t.name == "gesturelsm-stream"]


def test_bad_settings_raise_in_the_reader_and_failures_can_be_kept_going(tiny_pipeline, monkeypatch):
    with pytest.raises(InputError, match="either settings or a plan"):
        tiny_pipeline.stream(speech_like(1.0), settings=Settings(), plan=Plan())
    with pytest.raises(ValueError, match="output must be one of"):
        tiny_pipeline.stream(speech_like(1.0), output="cooked")
    with pytest.raises(InputError, match="Steps for DDIM"):
        list(tiny_pipeline.stream(speech_like(1.0), settings=Settings(methods=("ddim",), steps={"ddim": 10 ** 6})))
    real = tiny_pipeline.generate

    def broken(speech, **kw):
        if kw["method"] == "ddim":
            raise RuntimeError("out of memory")
        return real(speech, **kw)
    monkeypatch.setattr(tiny_pipeline, "generate", broken)
    settings = Settings(methods=("ddim", "rectified_flow"), steps={"ddim": 2, "rectified_flow": 1}, transcribe=False)
    made = [ev for ev in tiny_pipeline.stream(speech_like(1.5), settings=settings, keep_going=True)
            if isinstance(ev, Made)]
    assert [(x.method, type(x.error)) for x in made] == [("rectified_flow", type(None)), ("ddim", RuntimeError)]
    with pytest.raises(RuntimeError, match="out of memory"):
        list(tiny_pipeline.stream(speech_like(1.5), settings=settings))


def test_the_shipped_method_streams_its_windows_and_ends_as_generate(shipped_pipeline):
    """The shipped GestureLSM on 10 s of speech: windows of 128 frames, the method made equal to `generate`."""
    y = speech_like(10.0, seed=4)
    settings = Settings(steps={"gesturelsm": 2}, seed=9, transcribe=False)
    *windows, made = shipped_pipeline.stream(y, 16000, settings=settings)
    assert [w.frames for w in windows] == [48, 160, 300] and windows[-1].whole   # 16 latents behind the sampler
    raw = shipped_pipeline.generate(y, 16000, settings=settings, output="raw").motion
    _same(windows[-1].motion, raw)
    _same(made.motion, shipped_pipeline.generate(y, 16000, settings=settings).motion)
    joined = np.concatenate(_pieces(windows))
    np.testing.assert_allclose(joined, raw.poses, rtol=0, atol=1e-4)             # measured: about 1e-5 rad


@pytest.fixture(scope="module")
def shipped_pipeline():
    from gesturelsm.pipeline import ASSETS, GesturePipeline

    if not (ASSETS / "generator" / "gesturelsm.safetensors").exists():
        pytest.skip("the shipped checkpoints are not here")
    return GesturePipeline.from_pretrained(methods=["gesturelsm"], warm_up=False)


@pytest.mark.slow
def test_the_documented_stream_example_runs(tmp_path, monkeypatch, capsys):
    """docs/CLI.md's `pipe.stream` example, as written, on the shipped checkpoints: it saves each method's motion,
    the motion `generate` gives for it."""
    import re
    from pathlib import Path

    import soundfile as sf

    from gesturelsm.audio import load_audio
    from gesturelsm.pipeline import ASSETS, GesturePipeline

    if not (ASSETS / "generator" / "ddim.safetensors").exists():
        pytest.skip("the shipped checkpoints are not here")
    doc = (Path(__file__).resolve().parents[1] / "docs" / "CLI.md").read_text()
    code = re.search(r"`pipe\.stream` is the same generation.*?```python\n(.*?)```", doc, re.S).group(1)
    sf.write(tmp_path / "speech.wav", speech_like(6.0, seed=2), 16000)
    monkeypatch.chdir(tmp_path)
    pipe = GesturePipeline.from_pretrained(methods=["gesturelsm", "ddim"], warm_up=False)
    exec(compile(code, "docs/CLI.md", "exec"), {"pipe": pipe, "load_audio": load_audio, "Settings": Settings})
    printed = capsys.readouterr().out
    assert "gesturelsm raw so far: 180 frames (whole)" in printed and "ddim raw so far: 180 frames (whole)" in printed
    from gesturelsm.motion import MotionSequence

    for m in ("gesturelsm", "ddim"):
        one = Settings(methods=(m,), seed=3)
        _same(MotionSequence.load(tmp_path / f"{m}.npz"),
              pipe.generate(load_audio(tmp_path / "speech.wav"), 16000, settings=one).motion)
