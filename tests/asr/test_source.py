"""Transcript priority (typed > TextGrid > automatic > audio-only) in the pipeline step and the CLI."""
from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf

from gesturelsm.align import read_words, write_textgrid
from gesturelsm.asr import transcribe
from gesturelsm.asr.source import AUDIO_ONLY, AUTOMATIC, TEXTGRID, TYPED, automatic_words, transcript_source
from gesturelsm.cli import build_parser, main

from _asr_support import ENGLISH, SR
from _support import until


def test_recent_computes_each_key_once_even_when_asked_concurrently():
    """Four threads ask for one key while it is being computed: one computation, four equal answers; the oldest
    key is forgotten past `size`; if the computing caller fails, a waiting caller computes for itself."""
    import threading

    from gesturelsm.memo import Recent

    memo, calls, answers = Recent(2), [], []

    def waiting(key) -> int:
        """Callers waiting for the computation of `key` (its event's waiters)."""
        return len(memo._running[key]._cond._waiters)

    def slow(v, others: int = 0):
        def f():
            calls.append(v)
            if others:                                               # held until the other callers wait for it
                until(lambda: waiting("a") >= others, f"{others} more callers waited for 'a'")
            return v * 10
        return f

    threads = [threading.Thread(target=lambda: answers.append(memo.get("a", slow(1, others=3)))) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert calls == [1] and answers == [10] * 4
    memo.get("b", slow(2)), memo.get("c", slow(3))
    assert len(memo) == 2 and memo.get("a", slow(4)) == 40           # "a" was evicted: computed again
    failed, started, release, second = [], threading.Event(), threading.Event(), []

    def boom():
        failed.append(1)
        started.set()
        release.wait(30)
        raise RuntimeError("recogniser crashed")

    first = threading.Thread(target=lambda: pytest.raises(RuntimeError, memo.get, "d", boom))
    first.start()
    assert started.wait(30)                                          # "d" is being computed, and will fail
    waiter = threading.Thread(target=lambda: second.append(memo.get("d", slow(5))))
    waiter.start()
    until(lambda: waiting("d") == 1, "the second caller waited for the first")
    release.set()
    first.join()
    waiter.join()
    assert second == [50] and failed == [1]                          # it computed for itself, boom ran once


def test_automatic_words_remembers_by_content_and_hands_out_copies(monkeypatch):
    import gesturelsm.asr.source as source

    seen = []

    def fake(y, language="auto"):
        seen.append(len(y))
        return source.AutomaticWords([], "automatic transcript (fake)", None, ["note"])

    monkeypatch.setattr(source, "_recognised", fake)
    source.RECENT.clear()
    y = np.random.default_rng(0).normal(size=16000).astype(np.float32)
    a = source.automatic_words(y)
    a.warnings.append("changed by a caller")
    b = source.automatic_words(y.copy())                            # same samples, another array: remembered
    assert seen == [16000] and b.warnings == ["note"]
    y2 = y.copy()
    y2[100] += 1e-3
    source.automatic_words(y2)                                      # one sample differs: recognised again
    source.automatic_words(y, remember=False)                       # afresh on request
    assert seen == [16000] * 3
    source.RECENT.clear()


@pytest.mark.parametrize("text, textgrid, auto, want", [
    ("hello there", True, True, TYPED), ("  ", True, True, TEXTGRID), (None, True, False, TEXTGRID),
    ("", False, True, AUTOMATIC), (None, False, False, AUDIO_ONLY), ("hi", False, False, TYPED)])
def test_priority(text, textgrid, auto, want):
    assert transcript_source(text, textgrid, auto) == want


def test_generate_flags_are_exclusive_and_default_to_transcribing():
    p = build_parser()
    args = p.parse_args(["generate", "a.wav", "--out", "x.npz"])
    assert args.no_transcribe is False and args.text is None and args.textgrid is None
    assert p.parse_args(["generate", "a.wav", "--no-transcribe", "--out", "x.npz"]).no_transcribe
    for extra in (["--text", "hi"], ["--textgrid", "w.TextGrid"]):
        with pytest.raises(SystemExit):
            p.parse_args(["generate", "a.wav", "--no-transcribe", *extra, "--out", "x.npz"])


def test_automatic_words_accepts_english_and_refuses_german(recognizer, english, german):
    ok, no = automatic_words(english, language="en"), automatic_words(german, language="en")
    assert ok.words and ok.text_mode.startswith("automatic transcript") and ok.transcript.accepted
    assert no.words is None and no.text_mode.startswith("audio-only") and "English" in no.warnings[0]


def test_transcribe_cli_textgrid_round_trip(recognizer, english, tmp_path, capsys):
    wav, out = tmp_path / "speech.wav", tmp_path / "w" / "words.TextGrid"
    sf.write(wav, english, SR)
    assert main(["transcribe", str(wav), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    words = read_words(out)
    assert "word timings dtw" in printed and f"wrote {out}" in printed
    direct = transcribe(english).words                                    # the API gives the same words and times
    assert [w.text for w in words] == [w.text for w in direct] and len(words) >= len(ENGLISH.split()) - 2
    assert np.allclose([w.start for w in words], [w.start for w in direct], atol=1e-3)
    again = tmp_path / "again.TextGrid"
    write_textgrid(again, words, len(english) / SR)
    assert read_words(again) == words                                     # same layout as `gesturelsm align`
    assert main(["transcribe", str(wav), "--reference", str(out)]) == 0
    assert "mean 0 ms" in capsys.readouterr().out


def test_transcribe_cli_refuses_non_speech_with_one_line(recognizer, german, tmp_path, capsys):
    wav, out = tmp_path / "de.wav", tmp_path / "de.TextGrid"
    sf.write(wav, german, SR)
    assert main(["transcribe", str(wav), "--language", "en", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "may not be English" in err and "Nothing was written" in err and not out.exists()
    sf.write(wav, np.zeros(SR, np.float32), SR)
    assert main(["transcribe", str(wav)]) == 2
    assert "no speech" in capsys.readouterr().err


def test_words_recognised_earlier_keep_the_time_their_recognition_took(monkeypatch):
    """The transcription stage is timed where it ran: a remembered answer, or one another process recognised (the
    page's replicas prefetch it at the upload), says `earlier` and keeps that recognition's seconds."""
    import gesturelsm.asr.source as source

    monkeypatch.setattr(source, "_recognised", lambda y, language="auto": source.AutomaticWords([], "fake", None))
    source.RECENT.clear()
    y = np.random.default_rng(1).normal(size=16000).astype(np.float32)
    first = source.automatic_words(y)
    again = source.automatic_words(y)
    assert not first.earlier and first.seconds > 0
    assert again.earlier and again.seconds == first.seconds
    other = y + np.float32(1e-3)
    source.remember_words(other, source.AutomaticWords([], "fake", None, seconds=2.5))
    got = source.automatic_words(other)
    assert got.earlier and got.seconds == 2.5
    assert not source.automatic_words(other, remember=False).earlier
    source.RECENT.clear()
