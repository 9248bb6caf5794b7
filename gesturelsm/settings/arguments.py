"""The command line's side of the settings: the generation flags every command shares, made from each setting's
field (`fields.py`: flag, default, help) and the method specs (shown in `--help`), and the checks of the other
arguments (input files, output paths, thread counts), so a command refuses bad arguments with one line before it
loads a model or reads speech.

    add_settings_flags(parser, steps="one")            # --steps --cfg --seed
    add_post_flags(parser)                             # --smoothing --stand-in-place
    ...
    problems = []
    settings = cli_settings(args, methods=[args.method], problems=problems)
    audio = input_file(args.audio, "AUDIO", problems)
    out = output_file(args.out, "--out", ".npz", problems)
    refuse(problems)                                    # InputError: every problem, one per line
"""
from __future__ import annotations

import argparse
import math
import numbers
import os
from pathlib import Path
from typing import Any, Sequence

from ..errors import InputError
from .check import CLI, MISSING, Asked, settings_problems
from .defaults import MAX_SECONDS, Limits, Settings
from .fields import Setting
from .schema import named, settings_of
from .values import from_text, shown, whole_number


def default_steps_text(setting: str | None = None) -> str:
    """"GestureLSM 8, DDIM 20, ..." for the methods a step setting drives (None: every method)."""
    from ..backends import SPECS                                  # the method registry loads torch

    return ", ".join(f"{s.label} {s.default_steps}" for s in SPECS.values() if setting in (None, s.steps_setting))


def add_flag(p: Any, s: Setting, **own: Any) -> None:
    """The flag of one setting, with its default, its argparse options and its help (`fields.Setting`); `own`: what
    one command says otherwise (its own help or default)."""
    options = {"default": s.default, **s.argparse, **own}
    options.setdefault("help", s.help.format(default=s.default))
    p.add_argument(s.flag, **options)


def add_settings_flags(p: argparse.ArgumentParser, steps: str = "one", cls: type | None = None) -> None:
    """The step flags (`steps`: "one": --steps for the chosen method; "two": --steps and --ddim-steps as the page's
    two sliders; "none": the command adds its own), then the flag of every setting that goes with them (--cfg,
    --seed, and any setting added to the settings object `cls`). Numbers are read as text and checked by
    `cli_settings`."""
    if steps == "one":
        p.add_argument("--steps", type=from_text, default=MISSING,
                       help=f"sampling steps (default: the method's own: {default_steps_text()})")
    elif steps == "two":
        p.add_argument("--steps", type=from_text, default=MISSING,
                       help=f"sampling steps of the methods other than diffusion (default: each method's own: "
                            f"{default_steps_text('steps')})")
        p.add_argument("--ddim-steps", type=from_text, default=MISSING,
                       help=f"sampling steps of the diffusion methods (default: {default_steps_text('ddim_steps')})")
    for s in settings_of(cls):
        if s.cli == "settings":
            add_flag(p, s)


def add_post_flags(p: argparse.ArgumentParser) -> None:
    """--smoothing, --stand-in-place and --grounding: the post-processing of every motion (`PostProcess`)."""
    for name in ("smoothing", "stand_in_place", "grounding"):
        add_flag(p, named(name))


def add_grounding_flag(p: argparse.ArgumentParser) -> None:
    """--grounding on|off: the one flag every command that makes motion carries (generate, batch, sweep)."""
    add_flag(p, named("grounding"))


def grounding_on(args: argparse.Namespace) -> bool:
    return named("grounding").from_cli(getattr(args, "grounding", "on"))


def add_language_flag(p: argparse.ArgumentParser) -> None:
    """--language: the speech's language for recognition and for aligning a typed transcript."""
    add_flag(p, named("language"))


def add_methods_flag(p: Any, default: Any = None, help: str | None = None) -> None:
    """--methods (several): the methods a command runs; `default` and `help` where the command's differ."""
    add_flag(p, named("methods"), default=default, **({"help": help} if help is not None else {}))


def add_transcribe_flag(p: Any, help: str | None = None) -> None:
    """--no-transcribe: audio-only when no transcript is given (read back by `cli_asked` as `transcribe`); `p` is
    usually the group of the transcript's sources (--text, --textgrid); `help` where the command says it otherwise."""
    add_flag(p, named("transcribe"), **({"help": help} if help is not None else {}))


def add_max_seconds_flag(p: argparse.ArgumentParser) -> None:
    p.add_argument("--max-seconds", type=from_text, default=MAX_SECONDS,
                   help=f"longest speech accepted, seconds (default: {MAX_SECONDS:g})")


def cli_asked(args: argparse.Namespace, methods: Sequence[str] | None, cls: type | None = None) -> Asked:
    """The settings a command's flags sent (those it has; the others MISSING), by each setting's flag."""
    from ..backends import SPECS

    values = {s.name: s.from_cli(getattr(args, s.dest)) for s in settings_of(cls)
              if s.name not in ("methods", "steps", "ddim_steps") and hasattr(args, s.dest)}
    steps = getattr(args, "steps", MISSING)
    if hasattr(args, "ddim_steps"):          # two flags: each drives only its own methods, an omitted one none
        given = {"steps": steps, "ddim_steps": args.ddim_steps}
        steps = {m: given[SPECS[m].steps_setting] for m in methods or () if m in SPECS
                 and given[SPECS[m].steps_setting] is not MISSING}
    return Asked(methods=MISSING if methods is None else list(methods), steps=steps, **values)


def cli_settings(args: argparse.Namespace, methods: Sequence[str] | None, problems: list[str],
                 available: Sequence[str] | None = None, limits: Limits = Limits(),
                 cls: type | None = None) -> Settings | None:
    """The settings from a command's flags (those it has), checked by the one validator; None after adding problems."""
    from ..backends import GROUND_TRUTH, SPECS

    asked = cli_asked(args, methods, cls)
    settings, found = settings_problems(asked, list(available or [*SPECS, GROUND_TRUTH]), limits, CLI, cls=cls)
    problems += found
    return settings


def threads(value: Any, problems: list[str], field: str = "--threads") -> int | None:
    """A thread count from 1 to this machine's CPU count (None stays None: torch's own choice)."""
    if value is None:
        return None
    return whole_number(from_text(value), field, 1, os.cpu_count() or 1, problems)


def positive(value: Any, field: str, problems: list[str], hi: float | None = None) -> float | None:
    """A finite number above 0 (and at most `hi`)."""
    value = from_text(value)
    ok = not isinstance(value, bool) and isinstance(value, numbers.Real) and math.isfinite(float(value))
    if not ok or value <= 0 or (hi is not None and value > hi):
        most = f" and at most {hi:g}" if hi is not None else ""
        problems.append(f"{field} must be a number above 0{most} (got {shown(value)}).")
        return None
    return float(value)


def input_file(path: Any, field: str, problems: list[str]) -> Path | None:
    """A file that exists and is readable (not a folder)."""
    p = Path(path)
    if not p.exists():
        problems.append(f"{field} {p}: file not found.")
    elif p.is_dir():
        problems.append(f"{field} {p} is a folder; give a file.")
    elif not os.access(p, os.R_OK):
        problems.append(f"{field} {p}: the file cannot be read (permissions).")
    else:
        return p
    return None


def input_folder(path: Any, field: str, problems: list[str]) -> Path | None:
    p = Path(path)
    if not p.is_dir():
        problems.append(f"{field} {p}: " + ("is a file; give a folder." if p.exists() else "folder not found."))
        return None
    return p


def _blocked(p: Path) -> Path | None:
    """The first existing parent of `p` that is not a folder (then nothing can be written under it)."""
    for parent in p.parents:
        if parent.exists():
            return None if parent.is_dir() else parent
    return None


def output_file(path: Any, field: str, suffix: str, problems: list[str]) -> Path | None:
    """Where a file will be written, with `suffix` added when the name lacks it (as the writer would add it); not a
    folder, and under a folder (or a path that can become one)."""
    p = Path(path)
    if not p.name.endswith(suffix) and not p.is_dir():
        p = p.with_name(p.name + suffix)
    if p.is_dir():
        problems.append(f"{field} {p} is a folder; give a file name ending in {suffix}.")
    elif (bad := _blocked(p)) is not None:
        problems.append(f"{field} {p}: {bad} is a file, not a folder.")
    else:
        return p
    return None


def output_folder(path: Any, field: str, problems: list[str]) -> Path | None:
    """A folder that exists or can be made (not a file, nor under one)."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        problems.append(f"{field} {p} is a file; give a folder (it is made if missing).")
    elif (bad := _blocked(p)) is not None:
        problems.append(f"{field} {p}: {bad} is a file, not a folder.")
    else:
        return p
    return None


def refuse(problems: list[str]) -> None:
    """Raise every problem at once (one per line), if any."""
    if problems:
        raise InputError("\n".join(dict.fromkeys(problems)))


__all__ = ["add_flag", "add_language_flag", "add_max_seconds_flag", "add_methods_flag", "add_post_flags",
           "add_settings_flags", "add_transcribe_flag", "cli_asked",
           "cli_settings",
           "default_steps_text", "input_file",
           "input_folder", "output_file", "output_folder", "positive", "refuse", "threads"]
