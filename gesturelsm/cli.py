"""The `gesturelsm` command line. Each subcommand lives next to the code it drives and registers here.

A subcommand module exposes `add_parser(subparsers)` that creates its parser and sets `func=run(args)`. Every one is
imported when this module is, so a subcommand whose import breaks fails `import gesturelsm.cli` (and every test of the
command line) instead of quietly leaving the command out. Every option's `--help` shows its default (`WithDefaults`),
unless its own help already says it.
A problem the person can fix (`errors.GestureError`: bad files, bad settings) is printed as one line and exits with
status 2; anything else is a bug: "internal error" with its traceback on stderr, exit status 1.
"""
from __future__ import annotations

import argparse
import re
import sys
import traceback

from . import edit_cli, pipeline_cli
from .align import cli as align_cli
from .asr import cli as asr_cli
from .body import cli as body_cli
from .data import cli as data_cli
from .errors import GestureError
from .evaluation import cli as evaluation_cli
from .evaluation import sweep_cli
from .genea import cli as genea_cli
from .export import cli as export_cli
from .export import stream_cli
from .generator import cli as generator_cli
from .live import cli as live_cli
from .reference import cli as reference_cli
from .render import cli as render_cli
from .settings import MISSING
from .study import cli as batch_cli
from .study import study_cli
from .tokenizer import cli as tokenizer_cli
from .webapp import cli as webapp_cli

# in the order `gesturelsm --help` lists them
SUBCOMMANDS = (body_cli, data_cli, align_cli, asr_cli, tokenizer_cli, generator_cli, pipeline_cli, edit_cli,
               render_cli, export_cli, batch_cli, study_cli, genea_cli, evaluation_cli, sweep_cli, live_cli,
               stream_cli, reference_cli,
               webapp_cli)


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
    for module in SUBCOMMANDS:
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
