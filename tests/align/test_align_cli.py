"""`gesturelsm align`: a TextGrid out, words printed otherwise, one clear line for user errors."""
from __future__ import annotations

import numpy as np
import soundfile as sf

from gesturelsm.align import read_words
from gesturelsm.cli import main


def test_align_writes_a_textgrid_and_reports_against_a_reference(clip, tmp_path, capsys):
    wav = tmp_path / "speech.wav"
    sf.write(wav, clip.audio, 16000)
    out = tmp_path / "out" / "words.TextGrid"
    text = "The quick brown fox, jumps over the lazy dog... while 7 happy children sing loudly in the garden " \
           "behind our little house!"
    assert main(["align", str(wav), "--text", text, "--out", str(out), "--format", "short"]) == 0
    words = read_words(out)
    assert [w.text for w in words][:3] == ["The", "quick", "brown"] and words[10].text == "7"
    printed = capsys.readouterr().out
    assert "22 words, method dtw" in printed and f"wrote {out}" in printed
    assert main(["align", str(wav), "--text-file", str(_write(tmp_path / "t.txt", text)),
                 "--reference", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "onset error vs words.TextGrid: 22 words, mean 0 ms" in printed
    assert "  quick\n" in printed  # without --out the words are printed


def test_user_errors_are_one_line_with_exit_status_2(clip, tmp_path, capsys):
    wav = tmp_path / "speech.wav"
    sf.write(wav, clip.audio, 16000)
    cases = [
        (["align", str(wav)], "give the transcript with --text"),
        (["align", str(wav), "--text", "?!"], "no words to align"),
        (["align", str(tmp_path / "missing.wav"), "--text", "hi"], "not found"),
        (["align", str(wav), "--text", "hi", "--out", str(tmp_path / "x.json")], "must end in .TextGrid"),
        (["align", str(wav), "--text-file", str(tmp_path / "none.txt")], "transcript file not found"),
        (["align", str(wav), "--text", "hi", "--reference", str(_write(tmp_path / "bad.TextGrid", "x"))],
         "bad.TextGrid, line 1"),
    ]
    for argv, message in cases:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err.startswith("gesturelsm align: error:") and message in err and "\n" not in err, err


def test_fallbacks_are_explained_on_stderr(clip, tmp_path, capsys):
    wav = tmp_path / "speech.wav"
    sf.write(wav, clip.audio, 16000)
    out = tmp_path / "w.TextGrid"
    assert main(["align", str(wav), "--text", " ".join(clip.words * 12), "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "method even" in captured.out and "warning: The transcript is much longer" in captured.err
    assert len(read_words(out)) == 22 * 12


def _write(path, text: str):
    path.write_text(text, encoding="utf-8")
    return path


def test_language_takes_the_codes_of_the_other_commands_and_the_old_espeak_voice_names():
    from gesturelsm.commands.align import language_config
    from gesturelsm.align.languages import typed_alignment

    assert language_config("es", "hola").voices == ("es+klatt", "es+m7", "es+f3")
    assert language_config(" DE ", "hallo").voices[0] == "de+klatt"
    assert language_config("fr", "bonjour").voices[0] == "fr-fr+klatt"           # the code's voice, not its name
    assert language_config("auto", "hello") == language_config("en", "hello") == typed_alignment("auto", "hello")
    assert language_config("ja", "こんにちは").voices == ()                        # eSpeak does not read it
    # eSpeak NG voice names, what --language took before, are used as they are
    assert language_config("en-us", "hello").voices == ("en-us+klatt", "en-us+m7", "en-us+f3")
    assert language_config("en-gb-x-rp+f3", "hello").voices[0] == "en-gb-x-rp+klatt"
    assert language_config("pt-br", "olá").voices[0] == "pt-br+klatt"


def test_an_unknown_language_is_one_line_naming_the_codes(clip, tmp_path, capsys):
    wav = tmp_path / "speech.wav"
    sf.write(wav, clip.audio, 16000)
    assert main(["align", str(wav), "--text", "hi", "--language", "klingonese"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("gesturelsm align: error: --language 'klingonese' is neither a language code (auto en zh")
    assert " es " in err and " ja " in err and "voice eSpeak NG loads" in err and "\n" not in err


def test_a_spanish_transcript_is_timed_with_the_spanish_voice_from_the_command_line(clip_maker, tmp_path, capsys):
    text = "ayer por la tarde fuimos al mercado con mi hermana y compramos pan fresco manzanas y una botella de leche"
    clip = clip_maker(text.split(), voice="es+m3", pauses={6: 0.9})
    wav, out = tmp_path / "es.wav", tmp_path / "es.TextGrid"
    sf.write(wav, clip.audio, 16000)
    errors = {}
    for language in ("es", "en"):
        assert main(["align", str(wav), "--text", text, "--language", language, "--out", str(out)]) == 0
        errors[language] = np.mean(np.abs([w.start - t for w, t in zip(read_words(out), clip.onsets)]))
    assert "method dtw" in capsys.readouterr().out
    assert errors["es"] < 0.08 and errors["es"] < errors["en"]


def test_chinese_and_japanese_point_at_transcribe(clip, tmp_path, capsys):
    wav = tmp_path / "speech.wav"
    sf.write(wav, clip.audio, 16000)
    assert main(["align", str(wav), "--text", "我们昨天在公园散步", "--language", "zh"]) == 0
    captured = capsys.readouterr()
    assert "method even" in captured.out and "--language zh` recognises the words" in captured.err
