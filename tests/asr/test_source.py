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
    ok, no = automatic_words(english), automatic_words(german)
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
    assert main(["transcribe", str(wav), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "may not be English" in err and "Nothing was written" in err and not out.exists()
    sf.write(wav, np.zeros(SR, np.float32), SR)
    assert main(["transcribe", str(wav)]) == 2
    assert "no speech" in capsys.readouterr().err
