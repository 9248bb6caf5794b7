"""`gesturelsm align`: a TextGrid out, words printed otherwise, one clear line for user errors."""
from __future__ import annotations

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
