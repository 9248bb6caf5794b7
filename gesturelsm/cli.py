"""The `gesturelsm` command line: the registry of its subcommands (gesturelsm/commands/, one module per command).

A subcommand module has `NAME`, `HELP` and `add_parser(subparsers)` that creates its parser and sets `func=run(args)`.
Every one is imported when this module is, so a subcommand whose import breaks fails `import gesturelsm.cli` (and
every test of the command line) instead of quietly leaving the command out. `main` builds the parser of the command
it is given only (the others are listed by name and help line), so `gesturelsm --help` builds none and loads no
torch. Every option's `--help` shows its default (`WithDefaults`), unless its own help already says it.
A problem the person can fix (`errors.GestureError`: bad files, bad settings) is printed as one line and exits with
status 2; anything else is a bug: "internal error" with its traceback on stderr, exit status 1.
"""
from __future__ import annotations

import argparse
import re
import sys
import traceback

from .commands import (align, batch, bench, body, data, edit, eval_tokenizer, export, genea, generate, import_reference,
                       live, render, serve, stream, study, sweep, train, train_tokenizer, transcribe)
from .commands import eval as eval_command
from .errors import GestureError
from .settings import MISSING

# in the order `gesturelsm --help` lists them
SUBCOMMANDS = (body, data, align, transcribe, train_tokenizer, eval_tokenizer, train, generate, edit, render, export,
               batch, study, genea, eval_command, bench, sweep, live, stream, import_reference, serve)


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


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The command line's parser. `command`: only that command's parser is built (the others are listed, with their
    help line, but answer nothing); None: every command's."""
    parser = Parser(prog="gesturelsm", description="Speech-to-gesture generation (GestureLSM).")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for module in SUBCOMMANDS:
        if command is None or module.NAME == command:
            module.add_parser(sub)
        else:
            sub.add_parser(module.NAME, help=module.HELP)
    return parser


def _command(argv: list[str]) -> str:
    """The command `argv` names: its first word that is not an option ('' when none)."""
    return next((a for a in argv if not a.startswith("-")), "")


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(_command(argv))
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    try:
        result = args.func(args)
    except GestureError as exc:
        print(f"gesturelsm {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except Exception:                                   # a bug: say so, and keep everything needed to fix it
        print(f"gesturelsm {args.command}: internal error, please report it with the traceback below",
              file=sys.stderr)
        traceback.print_exc()
        return 1
    return int(result or 0)


if __name__ == "__main__":
    sys.exit(main())
