"""Every command checks its arguments before any work (the settings' validator, gesturelsm/settings): a bad value is
one line on stderr and exit status 2, before a model is loaded; every option shows its default in `--help`."""
from __future__ import annotations

import argparse
import re

import pytest
import soundfile as sf

from _support import speech_like
from gesturelsm.cli import build_parser, main
from gesturelsm.pipeline import GesturePipeline


@pytest.fixture
def places(tmp_path, monkeypatch):
    """{wav}: speech, {folder}: a folder, {speech}: a folder holding speech, {file}: a plain file, {tmp}: a fresh
    folder; loading a model fails the test."""
    sf.write(tmp_path / "s.wav", speech_like(1.0), 16000)
    (tmp_path / "folder").mkdir()
    (tmp_path / "speech").mkdir()
    sf.write(tmp_path / "speech" / "s.wav", speech_like(1.0), 16000)
    (tmp_path / "file.txt").write_text("not a folder")

    def no_work(*_a, **_k):
        raise AssertionError("a model was loaded although an argument is bad")
    monkeypatch.setattr(GesturePipeline, "from_pretrained", no_work)
    return {"wav": str(tmp_path / "s.wav"), "folder": str(tmp_path / "folder"), "file": str(tmp_path / "file.txt"),
            "speech": str(tmp_path / "speech"), "tmp": str(tmp_path)}


BAD = [
    ("generate {wav} --steps 0 --out {tmp}/m.npz", "--steps must be from 1 to 128 (got 0)"),
    ("generate {wav} --steps inf --out {tmp}/m.npz", "--steps must be a whole number from 1 to 128 (got inf"),
    ("generate {wav} --method ddim --steps 1001 --out {tmp}/m.npz", "--steps must be from 1 to 1000 (got 1001)"),
    ("generate {wav} --cfg 11 --out {tmp}/m.npz", "--cfg must be between 0 and 10 (got 11)"),
    ("generate {wav} --seed -1 --out {tmp}/m.npz", "--seed must be from 0 to 4294967295 (got -1)"),
    ("generate {folder} --out {tmp}/m.npz", "is a folder; give a file"),
    ("generate {tmp}/absent.wav --out {tmp}/m.npz", "file not found"),
    ("generate {wav} --out {folder}", "is a folder; give a file name ending in .npz"),
    ("generate {wav} --out {file}/m.npz", "is a file, not a folder"),
    ("generate {wav} --max-seconds 0 --out {tmp}/m.npz", "--max-seconds must be a number above 0"),
    ("sweep {wav} --steps inf --out {tmp}/o", "--steps must be whole numbers (got inf)"),
    ("sweep {wav} --steps 0 --out {tmp}/o", "--steps must be from 1 to"),
    ("sweep {wav} --threads -3 --out {tmp}/o", "--threads must be from 1 to"),
    ("sweep {wav} --threads 10000 --out {tmp}/o", "--threads must be from 1 to"),
    ("sweep {wav} --seeds 0 --out {tmp}/o", "--seeds must be from 1 to 4"),
    ("sweep {wav} --out {file}", "is a file; give a folder"),
    ("sweep {folder} --out {tmp}/o", "is a folder; give a file"),
    ("batch --audio-dir {speech} --out {file}", "is a file; give a folder"),
    ("batch --audio-dir {file} --out {tmp}/o", "--audio-dir {file}: is a file; give a folder"),
    ("batch --audio-dir {speech} --out {tmp}/o --steps 0", "--steps must be from 1 to 128 (got 0)"),
    ("batch --audio-dir {speech} --out {tmp}/o --ddim-steps 2000", "--ddim-steps must be from 1 to 1000 (got 2000)"),
    ("batch --audio-dir {speech} --out {tmp}/o --raters 0", "--raters must be from 1 to"),
    ("batch --audio-dir {speech} --out {tmp}/o --size 100", "--size must be from 128 to 1024"),
    ("batch --audio-dir {speech} --out {tmp}/o --methods gesturelsm ground_truth", "ground_truth needs --beat2"),
    ("eval --data {folder} --threads -3 --out {tmp}/o", "--threads must be from 1 to"),
    ("eval --data {folder} --steps 0 --out {tmp}/o", "--steps must be from 1 to"),
    ("eval --data {folder} --out {file}", "is a file; give a folder"),
    ("eval --data {file} --out {tmp}/o", "--data {file}: is a file; give a folder"),
    ("bench --threads 10000 --out {tmp}/o", "--threads must be from 1 to"),
    ("bench --repeats 0 --out {tmp}/o", "--repeats must be from 1 to"),
    ("live {wav} --threads 10000", "--threads must be from 1 to"),
    ("live {wav} --steps 0", "--steps must be from 1 to 128 (got 0)"),
    ("live {wav} --chunk-ms -5", "--chunk-ms must be a number above 0"),
    ("live {folder}", "is a folder; give a file"),
    ("live {wav} --out {folder}", "is a folder; give a file name ending in .npz"),
]


@pytest.mark.parametrize("command, message", BAD, ids=[c for c, _ in BAD])
def test_every_cli_argument_is_checked_before_any_work(places, capsys, command, message):
    argv = [part.format(**places) for part in command.split()]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"gesturelsm {argv[0]}: error: "), err
    assert message.format(**places) in err[0]


def test_every_problem_of_a_command_is_listed_at_once(places, capsys):
    assert main(["generate", places["folder"], "--steps", "0", "--cfg", "nan", "--out", places["folder"]]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert [line.split(" ")[0] for line in err[1:]] == ["--cfg", "AUDIO", "--out"] and "--steps" in err[0]


def _options(parser: argparse.ArgumentParser, name: str = "gesturelsm"):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub, p in action.choices.items():
                yield from _options(p, f"{name} {sub}")
        elif action.option_strings:
            yield name, parser, action


def test_every_option_shows_its_default_in_help():
    missing = []
    for name, parser, action in _options(build_parser()):
        d = action.default
        if action.required or d is None or d is False or d == argparse.SUPPRESS or d == [] or repr(d) == "MISSING" \
                or action.help == argparse.SUPPRESS:
            continue
        entry = " ".join(parser._get_formatter()._format_action(action).split())
        if not re.search(r"\(default\b|default: ", entry):
            missing.append(f"{name} {'/'.join(action.option_strings)}: {entry}")
    assert missing == []
