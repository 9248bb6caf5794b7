"""Every command and option of `gesturelsm` says what it is: each subcommand (nested ones too) has a one-line help in
its parent's list and a description in its own `--help`, each argument a help text, and each option with a default
shows it (the `WithDefaults` formatter adds it, or the help says it)."""
from __future__ import annotations

import argparse

import pytest

from gesturelsm.cli import STATED, build_parser
from gesturelsm.settings import MISSING


def _commands(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {c.dest: c.help for c in action._choices_actions}
            for name, sub in action.choices.items():
                yield (*path, name), sub, helps.get(name)
                yield from _commands(sub, (*path, name))


COMMANDS = list(_commands(build_parser()))


def _shown_default(action: argparse.Action) -> bool:
    d = action.default
    return not (action.required or d is None or d is False or d is MISSING or d == argparse.SUPPRESS or d == [])


def test_every_command_is_walked():
    names = {" ".join(path) for path, _, _ in COMMANDS}
    assert {"generate", "render", "data", "data info", "study invite", "body check", "serve"} <= names


@pytest.mark.parametrize("path, parser, help_line", COMMANDS, ids=[" ".join(c[0]) for c in COMMANDS])
def test_each_command_and_option_has_help_and_shows_its_default(path, parser, help_line):
    assert help_line and help_line.strip(), f"`gesturelsm {' '.join(path)}` has no line in its parent's help"
    assert parser.description and parser.description.strip(), f"`gesturelsm {' '.join(path)} --help` has no description"
    formatter = parser._get_formatter()
    for action in parser._actions:
        if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction)):
            continue
        name = "/".join(action.option_strings) or action.dest
        assert action.help and action.help.strip(), f"gesturelsm {' '.join(path)} {name} has no help"
        if action.option_strings and _shown_default(action):
            assert STATED.search(formatter._get_help_string(action)), f"{name} does not show its default"
    parser.format_help()                                  # renders (a stray % in a help would raise here)


def test_the_options_issue_51_named():
    by_path = {" ".join(path): parser for path, parser, _ in COMMANDS}
    render = {a.dest: a.help for a in by_path["render"]._actions}
    assert "default: the --style's own" in render["background"] and "default: 1" in render["supersample"]
    generate = by_path["generate"]
    assert "gesturelsm generate speech.wav --out out.npz" in generate.format_help()     # an example
    smoothing = next(a.help for a in generate._actions if a.dest == "smoothing")
    assert ".py" not in smoothing                                                     # no source file for a user
