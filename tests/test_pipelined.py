"""Speech preparation pipelined with generation: the words recognised window by window on a thread, each
generation window conditioned as soon as its words are final; the same motion, bit for bit, as the one-shot path."""
from __future__ import annotations

import math
import threading

import numpy as np
import pytest

import gesturelsm.pipeline as pipeline_module
import gesturelsm.pipelined as pipelined
from _support import speech_like
from gesturelsm.align import Word
from gesturelsm.asr.source import AutomaticWords
from gesturelsm.asr.transcribe import Piece, Transcript
from gesturelsm.asr.recognition_windows import recognition_cuts
from gesturelsm.constants import SAMPLE_RATE
from gesturelsm.features.text import TextEmbedder
from gesturelsm.pipelined import HIDDEN, WAITING, windowed_ready_points

SECONDS = 40.0


def _words(y: np.ndarray) -> list[Word]:
    """A word every 0.4 s, 0.3 s long, over the whole speech."""
    n = int(len(y) / SAMPLE_RATE / 0.4) - 1
    return [Word(f"word{i % 9}", 0.2 + 0.4 * i, 0.5 + 0.4 * i) for i in range(n)]


def fake_recogniser(accept: bool, calls: list):
    """automatic_words as the English model's windows would give it: `on_piece` per recognition window, then the
    transcript (accepted, or rejected: audio-only)."""
    def automatic_words(y, remember=True, language="auto", on_piece=None):
        words, cuts = _words(y), recognition_cuts(y)
        calls.append(on_piece is not None)
        for j, (a, b) in enumerate(zip(cuts, cuts[1:])):
            final = math.inf if j == len(cuts) - 2 else b / SAMPLE_RATE
            mine = [w for w in words if a / SAMPLE_RATE <= w.start < b / SAMPLE_RATE]
            if on_piece:
                on_piece(Piece(mine, final, "", -5.0, 10, "dtw", [], {}))
        if not accept:
            return AutomaticWords(None, "audio-only (automatic transcription rejected)", None, ["not English"])
        tr = Transcript(words, " ".join(w.text for w in words), "en", None, "dtw", [], True, 0.9,
                        details={"windows": len(cuts) - 1})
        return AutomaticWords(words, f"automatic transcript ({len(words)} words)", tr, [])
    return automatic_words


@pytest.fixture
def recogniser(monkeypatch):
    if not TextEmbedder.shared().available:
        pytest.skip("text encoder not installed")

    def use(accept: bool) -> list:
        calls: list = []
        fake = fake_recogniser(accept, calls)
        monkeypatch.setattr(pipelined, "automatic_words", fake)
        monkeypatch.setattr(pipeline_module, "automatic_words", fake)
        return calls
    return use


def _same(a, b) -> None:
    assert np.array_equal(a.poses, b.poses) and np.array_equal(a.trans, b.trans)
    assert np.array_equal(a.expressions, b.expressions)


def test_recognition_windows_are_cut_in_pauses_short_first():
    y = np.random.default_rng(0).normal(scale=0.1, size=int(SECONDS * SAMPLE_RATE)).astype(np.float32)
    y[int(9.0 * SAMPLE_RATE):int(9.3 * SAMPLE_RATE)] = 0            # a pause in the first window's search range
    cuts = recognition_cuts(y)
    assert cuts[0] == 0 and cuts[-1] == len(y) and len(cuts) >= 3
    assert 9.0 <= cuts[1] / SAMPLE_RATE <= 9.3
    lengths = np.diff(cuts) / SAMPLE_RATE
    assert lengths.max() <= 28.0 and lengths.min() >= 4.0             # never past Whisper's 30 s, no crumbs
    assert recognition_cuts(speech_like(12.0)) == [0, 12 * SAMPLE_RATE]   # short speech: one window


def test_pipelined_generation_gives_the_one_shot_motion_bit_for_bit(tiny_pipeline, recogniser):
    calls = recogniser(True)
    y = speech_like(SECONDS)
    one = tiny_pipeline.prepare_speech(y, SAMPLE_RATE)
    assert one.stream is None and one.ready_points == windowed_ready_points(one.audio, one.num_frames)
    assert len(one.ready_points) >= 3
    streamed = tiny_pipeline.prepare_speech(y, SAMPLE_RATE, stream=True)
    assert streamed.stream is not None
    a = tiny_pipeline.generate(one, steps=2, seed=3, output="raw")
    b = tiny_pipeline.generate(streamed, steps=2, seed=3, output="raw")
    assert calls == [False, True]                                      # one-shot, then window by window
    _same(a.motion, b.motion)
    assert b.text_mode == a.text_mode and HIDDEN in b.timings and WAITING in b.timings
    assert b.timings[HIDDEN] <= b.timings["transcription"]
    done = tiny_pipeline.settled(streamed)
    assert done.stream is None and [w.text for w in done.words] == [w.text for w in one.words]
    assert np.array_equal(done.word_features.numpy(), one.word_features.numpy())
    c = tiny_pipeline.generate(y, SAMPLE_RATE, steps=2, seed=3, output="raw")        # raw audio: pipelined by default
    _same(a.motion, c.motion)
    ranges = {"upper": [(20.0, 30.0)]}                                 # an edit of samples streams its words too
    e1 = tiny_pipeline.edit(a.motion, one, ranges, steps=2, seed=4)
    e2 = tiny_pipeline.edit(a.motion, y, ranges, steps=2, seed=4, sr=SAMPLE_RATE)
    _same(e1.motion, e2.motion)
    assert HIDDEN in e2.timings and e2.text_mode == a.text_mode and calls == [False, True, True, True]


@pytest.mark.parametrize("seconds", [SECONDS, 6.0])                # generated before the verdict, or stopped
def test_a_rejected_transcript_regenerates_as_the_one_shot_path(tiny_pipeline, recogniser, seconds):
    recogniser(False)                                                  # words streamed, then rejected
    y = speech_like(seconds, seed=1)
    one = tiny_pipeline.prepare_speech(y, SAMPLE_RATE)
    assert one.words is None and one.ready_points == ()
    b = tiny_pipeline.generate(tiny_pipeline.prepare_speech(y, SAMPLE_RATE, stream=True), steps=2, seed=0, output="raw")
    a = tiny_pipeline.generate(one, steps=2, seed=0, output="raw")
    _same(a.motion, b.motion)
    assert b.text_mode.startswith("audio-only") and "not English" in b.warnings


def test_the_words_are_recognised_while_the_audio_features_are_made(tiny_pipeline, monkeypatch):
    """prepare_speech(stream=True) starts the recogniser before it computes the audio features, and the finished
    speech keeps those features."""
    if not TextEmbedder.shared().available:
        pytest.skip("text encoder not installed")
    started, seen = threading.Event(), []
    real = pipeline_module.audio_channels

    def words(y, remember=True, language="auto", on_piece=None):
        started.set()
        return AutomaticWords(None, "audio-only (automatic transcription rejected)", None, ["not English"])

    def channels(y, sr=SAMPLE_RATE):
        seen.append(started.wait(30) if len(y) > SAMPLE_RATE else None)     # not the one-off warm-up's noise
        return real(y, sr)
    monkeypatch.setattr(pipeline_module, "automatic_words", words)
    monkeypatch.setattr(pipeline_module, "audio_channels", channels)
    y = speech_like(6.0, seed=4)
    speech = tiny_pipeline.prepare_speech(y, stream=True)
    assert [s for s in seen if s is not None] == [True]
    done = tiny_pipeline.settled(speech)
    assert done.channels is speech.channels and done.words is None and done.text_mode.startswith("audio-only")


class Stopped(Exception):
    """What a stopped request's progress raises."""


@pytest.mark.parametrize("fails", ["features", "progress"])
def test_speech_whose_preparation_stops_ends_its_words_thread(tiny_pipeline, monkeypatch, fails):
    """The audio features fail, or the request is stopped (its progress raises) after the recogniser started: the
    error reaches the caller and the words thread does not wait forever for the speech."""
    if not TextEmbedder.shared().available:
        pytest.skip("text encoder not installed")
    threads = []

    def words(y, remember=True, language="auto", on_piece=None):
        threads.append(threading.current_thread())
        return AutomaticWords(None, "audio-only (automatic transcription rejected)", None, ["not English"])

    def broken(y, sr=SAMPLE_RATE):
        raise Stopped("no room for the features")

    def progress(fraction, message):
        if message == "audio features":
            raise Stopped("the visitor pressed Stop")
    monkeypatch.setattr(pipeline_module, "automatic_words", words)
    monkeypatch.setattr(pipeline_module, "warm_audio_features", lambda: 0.0)
    if fails == "features":
        monkeypatch.setattr(pipeline_module, "audio_channels", broken)
    before = set(threading.enumerate())
    with pytest.raises(Stopped):
        tiny_pipeline.prepare_speech(speech_like(3.0, seed=4), stream=True, progress=progress)
    started = [t for t in threading.enumerate() if t.name == "gesturelsm-words" and t not in before] + threads
    assert started                                   # the recogniser had been started
    for t in started:
        t.join(30)
        assert not t.is_alive()
