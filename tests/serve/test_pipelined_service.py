"""The page's click joins the upload's pipelined speech preparation (gesturelsm/serve/service.py `speech`,
serve/progressive.py): the upload's words are recognised window by window on a thread, the click does not wait for
all of them (generation of the first method works on the first windows while later ones are still recognised), the
recogniser runs once for the upload and the click, and every method's motion is the one-shot path's, bit for bit."""
from __future__ import annotations

import math
import threading

import numpy as np
import pytest
import soundfile as sf

import gesturelsm.pipeline as pipeline_module
import gesturelsm.pipelined as pipelined
from _support import speech_like
from gesturelsm.align import Word
from gesturelsm.asr.source import AutomaticWords
from gesturelsm.asr.transcribe import Piece, Transcript
from gesturelsm.asr.recognition_windows import recognition_cuts
from gesturelsm.constants import SAMPLE_RATE
from gesturelsm.features.text import TextEmbedder
from gesturelsm.serve.request import Request

SECONDS = 30.0                                       # two recognition windows
ALL = ["gesturelsm", "rectified_flow", "ddim"]
STEPS = {"gesturelsm": 2, "rectified_flow": 1, "ddim": 2}


def gated_recogniser(calls: list, gate: threading.Event):
    """automatic_words as the English model gives it window by window (`on_piece`), holding every window after the
    first until `gate` is set; a word every 0.4 s."""
    def automatic_words(y, remember=True, language="auto", on_piece=None):
        n = int(len(y) / SAMPLE_RATE / 0.4) - 1
        words = [Word(f"word{i % 7}", 0.2 + 0.4 * i, 0.5 + 0.4 * i) for i in range(n)]
        cuts = recognition_cuts(y)
        calls.append(on_piece is not None)
        for j, (a, b) in enumerate(zip(cuts, cuts[1:])):
            if j:
                assert gate.wait(120), "nobody asked for the later words"
            final = math.inf if j == len(cuts) - 2 else b / SAMPLE_RATE
            if on_piece:
                on_piece(Piece([w for w in words if a / SAMPLE_RATE <= w.start < b / SAMPLE_RATE], final, "", -5.0,
                               10, "dtw", [], {}))
        tr = Transcript(words, " ".join(w.text for w in words), "en", None, "dtw", [], True, 0.9,
                        details={"windows": len(cuts) - 1})
        return AutomaticWords(words, f"automatic transcript ({len(words)} words)", tr, [])
    return automatic_words


@pytest.fixture
def long_service(tiny_assets, tmp_path):
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.service import GestureService

    if not TextEmbedder.shared().available:
        pytest.skip("text encoder not installed")
    return GestureService.from_settings(ServiceSettings(checkpoints=str(tiny_assets), max_seconds=40, ahead=False,
                                                        workdir=str(tmp_path / "work")))


@pytest.fixture
def recognising(monkeypatch):
    """The gated recogniser in place of the real one; yields (calls, gate, waits: (frames, words finished) each time
    generation asked for words)."""
    calls, gate, waits = [], threading.Event(), []
    fake = gated_recogniser(calls, gate)
    monkeypatch.setattr(pipelined, "automatic_words", fake)
    monkeypatch.setattr(pipeline_module, "automatic_words", fake)
    wait = pipelined.PendingWords.wait

    def watched(self, frames):
        waits.append((frames, self.done))
        if frames > self._ready:                     # generation needs words not recognised yet: let them come
            gate.set()
        return wait(self, frames)
    monkeypatch.setattr(pipelined.PendingWords, "wait", watched)
    yield calls, gate, waits
    gate.set()                                       # a test that failed leaves no thread waiting


def test_the_click_joins_the_uploads_words_and_makes_the_one_shot_motion(long_service, recognising, tmp_path):
    calls, gate, waits = recognising
    wav = tmp_path / "speech.wav"
    sf.write(wav, speech_like(SECONDS, seed=5), SAMPLE_RATE)
    req = Request(str(wav), methods=ALL, steps=dict(STEPS), exports=False, render=False)
    assert long_service.prefetch(str(wav))                  # the upload: audio features ready, words on a thread
    assert not gate.is_set()
    results = list(long_service.stream(req))
    assert calls == [True]                                  # the click joined the upload's recognition
    assert any(frames > 0 and not done for frames, done in waits)   # generated before the words were all known
    first, last = results[0], results[-1]
    assert first.motions == {} and first.text_mode == pipelined.PENDING_MODE
    assert last.text_mode.startswith("automatic transcript") and last.transcript.startswith("word0 word1")
    assert last.speech.stream is None and len(last.speech.words) == len(last.transcript.split())
    assert list(last.motions) == ALL and last.failed == {}

    # the one-shot path: the same speech prepared whole, then every method
    audio = long_service.uploads.decoded(str(wav), lambda: None)
    speech = long_service.pipeline.prepare_speech(audio, SAMPLE_RATE)
    assert speech.stream is None and calls == [True, False]
    _, plan = long_service.check(req)
    for made in long_service.pipeline.generate_each(speech, plan, body=long_service.body):
        got = last.motions[made.method]
        assert np.array_equal(got.poses, made.motion.poses) and np.array_equal(got.trans, made.motion.trans)
        assert np.array_equal(got.expressions, made.motion.expressions)
    assert np.array_equal(last.speech.word_features.numpy(), speech.word_features.numpy())

    again = list(long_service.stream(req))[-1]              # the upload's words are kept: nothing recognised again
    assert calls == [True, False] and again.text_mode == last.text_mode
    assert np.array_equal(again.motions["gesturelsm"].poses, last.motions["gesturelsm"].poses)


def test_a_settled_caller_gets_the_finished_speech_and_a_failed_recognition_is_tried_again(long_service, monkeypatch,
                                                                                             tmp_path):
    attempts, failing = [], [True]

    def fails_once(y, remember=True, language="auto", on_piece=None):
        attempts.append(on_piece is not None)
        if failing[0]:
            raise RuntimeError("the recogniser fell over")
        return AutomaticWords([Word("hello", 0.3, 0.7)], "automatic transcript (1 word)", None)
    monkeypatch.setattr(pipelined, "automatic_words", fails_once)
    monkeypatch.setattr(pipeline_module, "automatic_words", fails_once)
    wav = tmp_path / "short.wav"
    sf.write(wav, speech_like(3.0, seed=2), SAMPLE_RATE)
    req = Request(str(wav), methods=["rectified_flow"], steps={"rectified_flow": 1}, exports=False, render=False)
    with pytest.raises(RuntimeError, match="fell over"):
        long_service.speech(req, None, lambda f, m: None)     # waits for the words: their error
    failing[0] = False
    tried = len(attempts)
    _, speech, _ = long_service.speech(req, None, lambda f, m: None)   # forgotten, so prepared again
    assert speech.stream is None and [w.text for w in speech.words] == ["hello"] and len(attempts) == tried + 1
