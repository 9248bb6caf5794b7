"""The page's language on Ray Serve replicas (gesturelsm/serve/replicated.py, replicas.py), without Ray: the
transcript prefetched while the visitor chooses the settings is made in the page's language and goes with a request
only in that language; the replica transcribes and remembers the words in it."""
from __future__ import annotations

from types import SimpleNamespace

import pytest
import soundfile as sf

from _support import speech_like
from gesturelsm.serve.replicas import GestureReplica, Scratch, Upload
from gesturelsm.serve.replicated import ReplicatedService
from gesturelsm.serve.request import Request


class Sent(Exception):
    """What the fake replica was asked to run (the test stops there)."""


@pytest.fixture
def front(service, tmp_path):
    calls = []
    svc = ReplicatedService(service.pipeline, service.settings, service.body, handle=None, count=None)

    def call(method, *args, cancelled=None):
        calls.append((method, args))
        if method == "transcribe":
            return SimpleNamespace(text_mode=f"words in {args[1]}")
        raise Sent(method)
    svc.generation.call = call
    wav = tmp_path / "speech.wav"
    sf.write(wav, speech_like(2.0, seed=3), 16000)
    return svc, calls, wav


def test_the_prefetch_transcribes_in_the_pages_language_and_only_that_language_goes_with_the_request(front):
    svc, calls, wav = front
    assert svc.prefetch(str(wav), ahead=Request(str(wav), language=" ES ")) is True
    assert calls[-1][0] == "transcribe" and calls[-1][1][1] == "es"
    assert svc.prefetch(str(wav)) is True and calls[-1][1][1] == "auto"       # no settings yet: auto
    for language, heard in (("es", "words in es"), ("auto", "words in auto"), ("ja", None)):
        with pytest.raises(Sent):
            svc.run(Request(str(wav), methods=["gesturelsm"], language=language, render=False, exports=False))
        (method, (req, _, _, words, _)) = calls[-1]
        assert method == "run" and req.language == language and (words.text_mode if words else None) == heard
    assert svc.prefetch(str(wav), ahead=Request(str(wav), language="klingon")) is False     # refused at the click


def test_a_replica_transcribes_and_remembers_in_the_requests_language(tmp_path):
    seen = []
    pipeline = SimpleNamespace(prefetch_transcript=lambda y, sr, language: seen.append(("prefetch", language)),
                               remember_transcript=lambda y, sr, words, language: seen.append(("remember", language)))
    service = SimpleNamespace(settings=SimpleNamespace(max_seconds=20), pipeline=pipeline,
                              run=lambda req: (_ for _ in ()).throw(Sent("run")))
    replica = SimpleNamespace(scratch=Scratch(tmp_path), service=service)
    wav = tmp_path / "speech.wav"
    sf.write(wav, speech_like(2.0, seed=3), 16000)
    upload = Upload(wav.name, wav.read_bytes())
    GestureReplica.transcribe(replica, upload, "ja")
    with pytest.raises(Sent):
        GestureReplica.run(replica, Request(str(wav), language="ja"), upload, words=SimpleNamespace())
    assert seen == [("prefetch", "ja"), ("remember", "ja")]
