"""The `gesturelsm` command line. Each subcommand lives next to the code it drives and registers here.

A subcommand module exposes `add_parser(subparsers)` that creates its parser and sets `func=run(args)`.
User errors (`errors.GestureError`: bad files, bad settings) are printed as one clear line and exit with status 2.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from .errors import GestureError

# module paths of subcommands; each has add_parser(subparsers)
SUBCOMMANDS: tuple[str, ...] = (
    "gesturelsm.body.cli",
    "gesturelsm.data.cli",
    "gesturelsm.align.cli",
    "gesturelsm.asr.cli",
    "gesturelsm.tokenizer.cli",
    "gesturelsm.generator.cli", "gesturelsm.pipeline_cli", "gesturelsm.edit_cli",
    "gesturelsm.render.cli", "gesturelsm.export.cli",
    "gesturelsm.study.cli", "gesturelsm.study.study_cli",
    "gesturelsm.evaluation.cli",
    "gesturelsm.evaluation.sweep_cli",
    "gesturelsm.live.cli",
    "gesturelsm.reference.cli",
    "gesturelsm.webapp.cli",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="gesturelsm", description="Speech-to-gesture generation (GestureLSM).")
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
