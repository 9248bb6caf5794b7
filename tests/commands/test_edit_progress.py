"""`gesturelsm edit`'s progress: a long motion's windows (2,250 for 30 minutes) are a few lines in a log and one
redrawn line on a terminal, while every other step is printed as it comes (progress.Line, the command line's one
renderer)."""
from __future__ import annotations

import io
import re

import soundfile as sf

from gesturelsm.cli import main
from gesturelsm.progress import Line as WindowSteps

from _support import speech_like, synthetic_motion


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def _feed(steps: WindowSteps, windows: int) -> None:
    steps(0.1, "audio features")
    for i in range(1, windows + 1):
        steps(0.2 + 0.7 * i / windows, f"gesturelsm: window {i}/{windows}")
    steps(1.0, "gesturelsm: edited upper 600-606 s")


def test_thirty_minutes_of_windows_are_twelve_lines_in_a_log():
    log = io.StringIO()
    _feed(WindowSteps(log), 2250)
    lines = log.getvalue().splitlines()
    windows = [line for line in lines if "window" in line]
    assert [re.search(r"window (\d+)/2250", w).group(1) for w in windows] == [
        "1", "225", "450", "675", "900", "1125", "1350", "1575", "1800", "2025", "2250"]
    assert lines[0] == "[ 10 %] audio features" and lines[-1] == "[100 %] gesturelsm: edited upper 600-606 s"
    assert windows[0] == "[ 20 %] gesturelsm: window 1/2250"
    assert re.fullmatch(r"\[ 90 %\] gesturelsm: window 2250/2250 \(\d+\.\d s since window 1\)", windows[-1])


def test_a_short_motion_shows_every_window_and_a_new_pass_starts_over():
    log = io.StringIO()
    steps = WindowSteps(log)
    _feed(steps, 3)
    _feed(steps, 3)                                   # a second sampling pass of the same length
    windows = [line.split("] ")[1].split(" (")[0] for line in log.getvalue().splitlines() if "window" in line]
    assert windows == [f"gesturelsm: window {i}/3" for i in (1, 2, 3)] * 2


def test_on_a_terminal_the_windows_are_one_line_redrawn():
    tty = Terminal()
    _feed(WindowSteps(tty), 2250)
    text = tty.getvalue()
    assert text.count("\r\033[K") == 2250
    lines = text.split("\n")
    assert lines[0] == "[ 10 %] audio features"
    assert lines[1].rsplit("\r\033[K", 1)[1] == "[ 90 %] gesturelsm: window 2250/2250"     # the last drawn
    assert lines[2] == "[100 %] gesturelsm: edited upper 600-606 s" and lines[3] == ""


def test_the_edit_command_prints_its_windows_in_steps(tiny_assets, tmp_path, capsys):
    seconds = 40
    synthetic_motion(frames=30 * seconds, seed=2).save(tmp_path / "m.npz")
    sf.write(tmp_path / "m.wav", speech_like(seconds, seed=2), 16000)
    assert main(["edit", str(tmp_path / "m.npz"), str(tmp_path / "m.wav"), "--regenerate", "upper@20-22",
                 "--checkpoints", str(tiny_assets), "--steps", "1", "--no-transcribe",
                 "--out", str(tmp_path / "e.npz")]) == 0
    err = capsys.readouterr().err.splitlines()
    windows = [re.search(r"window (\d+)/(\d+)", line).groups() for line in err if re.search(r"window \d+/", line)]
    total = int(windows[0][1])
    assert total > 20 and windows[0][0] == "1" and windows[-1] == (str(total), str(total))
    assert len(windows) <= 11                         # the first, one per tenth, the last
    assert any("edited" in line for line in err)
