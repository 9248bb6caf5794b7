"""`gesturelsm --help`, and the `--help` of every command whose options show no method, load no torch: the command
modules import at their top only what a parser needs without torch, and the registry builds only the parser of the
command it is given (gesturelsm/commands/__init__.py). Checked as a person runs them, with `python -X importtime`,
whose report lists every module the process imported."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
# commands whose options show the methods or the body regions (the registry that declares them loads torch)
SHOWS_THE_REGISTRY = {"train-tokenizer", "train", "generate", "edit", "batch", "genea", "sweep", "live"}


def imported(*args: str) -> tuple[set[str], str]:
    """(every module `python -X importtime <args>` imported, its stdout)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, (str(REPO), os.environ.get("PYTHONPATH"))))}
    run = subprocess.run([sys.executable, "-X", "importtime", *args], capture_output=True, text=True, env=env,
                         cwd=REPO, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    rows = [line.rsplit("|", 1) for line in run.stderr.splitlines() if line.startswith("import time:")]
    modules = {row[1].strip() for row in rows if len(row) == 2}
    assert "gesturelsm" in modules, run.stderr[-2000:]            # the report was read
    return modules, run.stdout


def _commands() -> list[str]:
    from gesturelsm.cli import SUBCOMMANDS

    return [m.NAME for m in SUBCOMMANDS]


def test_gesturelsm_help_loads_no_torch():
    modules, out = imported("-m", "gesturelsm", "--help")
    assert "generate" in out and "import-reference" in out
    assert not {m for m in modules if m == "torch" or m.startswith("torch.")}
    assert not {m for m in modules if m.startswith(("gesturelsm.backends", "gesturelsm.pipeline", "gesturelsm.flows",
                                                    "gesturelsm.generator", "gesturelsm.motion"))}


@pytest.mark.parametrize("command", sorted(set(_commands()) - SHOWS_THE_REGISTRY))
def test_the_help_of_a_command_that_shows_no_method_loads_no_torch(command):
    modules, out = imported("-m", "gesturelsm", command, "--help")
    assert f"gesturelsm {command}" in out
    assert "torch" not in modules


def test_the_settings_load_no_torch():
    modules, _ = imported("-c", "import gesturelsm.settings, gesturelsm.settings.arguments")
    assert "torch" not in modules


def test_the_commands_that_show_the_registry_are_commands():
    assert SHOWS_THE_REGISTRY <= set(_commands())
