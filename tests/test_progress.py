"""The progress helper (gesturelsm/progress.py): spans compose, the stages of each kind of work are declared once and
in order, and the command line's one renderer (`Line`) writes one line per step, a counted series as one line
redrawn on a terminal and as its first, each tenth and its last line in a log."""
from __future__ import annotations

import io
import re

import pytest

from gesturelsm.progress import GENERATION, REQUEST, SWEEP_REQUEST, Line, Stages, span


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_spans_compose_and_nobody_listening_stays_none():
    said = []
    outer = span(lambda f, m: said.append((round(f, 6), m)), 0.2, 0.6, prefix="a: ")
    inner = span(outer, 0.5, 1.0, prefix="b: ")
    inner(0.0, "x")
    inner(0.5, "y")
    inner(1.0, "z")
    assert said == [(0.4, "a: b: x"), (0.5, "a: b: y"), (0.6, "a: b: z")]
    assert span(None, 0.1, 0.2) is None and REQUEST.span(None, "methods") is None


def test_the_stages_are_declared_in_order_and_say_where_each_begins():
    assert REQUEST.at("speech") == 0.02 and REQUEST["methods"] == (0.12, 0.62) and REQUEST.at("video") == 0.62
    assert list(REQUEST) == ["speech", "methods", "video", "exports"]
    assert GENERATION["method"] == (0.2, 0.9) and SWEEP_REQUEST["sweep"] == (0.1, 0.95)
    said = []
    REQUEST.span(lambda f, m: said.append(round(f, 6)), "video")(0.5, "frame 5/10")
    assert said == [0.77]
    for bad in ({"a": (0.5, 0.4)}, {"a": (0.0, 0.5), "b": (0.4, 0.9)}, {"a": (0.0, 1.5)}):
        with pytest.raises(ValueError, match="in order"):
            Stages(**bad)


def test_in_a_log_a_series_is_its_first_each_tenth_and_its_last_line():
    log = io.StringIO()
    line = Line(log)
    line(0.0, "loading the models (gesturelsm)")
    for k in range(1, 101):
        line(k / 100, f"frame {k}/100 ({k:.1f} fps)")
    line(1.0, "wrote out.mp4")
    lines = log.getvalue().splitlines()
    assert lines[0] == "[  0 %] loading the models (gesturelsm)" and lines[-1] == "[100 %] wrote out.mp4"
    frames = lines[1:-1]
    assert frames[0] == "[  1 %] frame 1/100 (1.0 fps)"
    assert [int(re.search(r"frame (\d+)/", f).group(1)) for f in frames] == [1, 10, 20, 30, 40, 50, 60, 70, 80, 90,
                                                                            100]
    assert all(re.search(r"\(\d+\.\d s since frame 1\)$", f) for f in frames[1:])


def test_a_series_without_a_noun_says_no_time_and_starts_over_when_its_count_does():
    log = io.StringIO()
    line = Line(log)
    for k in (0, 1, 2):
        line(k / 2, f"{k}/2 videos")
    line(0.0, "0/2 videos")                                  # a second run: a new series
    assert log.getvalue().splitlines() == ["[  0 %] 0/2 videos", "[ 50 %] 1/2 videos", "[100 %] 2/2 videos",
                                           "[  0 %] 0/2 videos"]


def test_on_a_terminal_a_series_is_one_line_redrawn_and_other_lines_keep_it():
    tty = Terminal()
    line = Line(tty)
    line(0.1, "audio features")
    line(0.2, "window 1/3")
    line.write("  a note")                                   # erases the redrawn line, which comes back next step
    line(0.4, "window 2/3")
    line(0.5, "speech transcribed")                          # a step of its own: the redrawn line stays
    line(0.9, "window 3/3")
    line(1.0, "done")
    assert tty.getvalue() == ("[ 10 %] audio features\n"
                              "\r\033[K[ 20 %] window 1/3\r\033[K  a note\n"
                              "\r\033[K[ 40 %] window 2/3\n[ 50 %] speech transcribed\n"
                              "\r\033[K[ 90 %] window 3/3\n[100 %] done\n")


def test_the_line_writes_where_stderr_is_when_it_is_called(capsys):
    line = Line()
    line(0.5, "half")
    assert capsys.readouterr().err == "[ 50 %] half\n"
