"""The `gesturelsm` command line. Each subcommand lives next to the code it drives and registers here.

A subcommand module exposes `add_parser(subparsers)` that creates its parser and sets `func=run(args)`. Every
option's `--help` shows its default (`WithDefaults`), unless its own help already says it.
User errors (`errors.GestureError`: bad files, bad settings) are printed as one clear line and exit with status 2.
"""
from __future__ import annotations

import argparse
import importlib
import re
import sys

from .errors import GestureError
from .settings import MISSING

# module paths of subcommands; each has add_parser(subparsers)
SUBCOMMANDS: tuple[str, ...] = (
    "gesturelsm.body.cli",
    "gesturelsm.data.cli",
    "gesturelsm.align.cli",
    "gesturelsm.asr.cli",
    "gesturelsm.tokenizer.cli",
    "gesturelsm.generator.cli", "gesturelsm.pipeline_cli",
    "gesturelsm.render.cli", "gesturelsm.export.cli",
    "gesturelsm.study.cli", "gesturelsm.study.study_cli",
    "gesturelsm.evaluation.cli",
    "gesturelsm.evaluation.sweep_cli",
    "gesturelsm.live.cli",
    "gesturelsm.reference.cli",
    "gesturelsm.webapp.cli",
)


STATED = re.compile(r"\(default\b|default: ")      # a help text that says its default already


class WithDefaults(argparse.HelpFormatter):
    """Adds "(default: X)" to an option's help when it has a default to show (not None, False, [] or MISSING) and
    the help does not already say its default."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        d = action.default
        if (not action.option_strings or action.required or STATED.search(text) or d is MISSING or d is None
                or d is False or d == argparse.SUPPRESS or d == []):
            return text
        shown = " ".join(map(str, d)) if isinstance(d, (list, tuple)) else str(d)
        return f"{text} (default: {shown.replace('%', '%%')})".strip()


def with_defaults(formatter: type) -> type:
    """`formatter` that also shows defaults (WithDefaults first, so its help string wins)."""
    if issubclass(formatter, WithDefaults):
        return formatter
    return type(f"{formatter.__name__}WithDefaults", (WithDefaults, formatter), {})


class Parser(argparse.ArgumentParser):
    """The command line's parsers (subcommands' too: argparse makes them of the parent's class)."""

    def __init__(self, *args, formatter_class: type = argparse.HelpFormatter, **kwargs):
        super().__init__(*args, formatter_class=with_defaults(formatter_class), **kwargs)


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="gesturelsm", description="Speech-to-gesture generation (GestureLSM).")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for mod in SUBCOMMANDS:
        try:
            module = importlib.import_module(mod)
        except ModuleNotFoundError as exc:
            if exc.name and mod.startswith(exc.name):  # that subcommand is not part of this build
                continue
            raise
        module.add_parser(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    try:
        result = args.func(args)
    except (GestureError, FileNotFoundError, ValueError) as exc:   # ValueError: argument checks of library code
        print(f"gesturelsm {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    return int(result or 0)


if __name__ == "__main__":
    sys.exit(main())
