"""`gesturelsm --help` and the `--help` of every command load no torch: the command modules import at their top only
what a parser needs without torch, the registry builds only the parser of the command it is given
(gesturelsm/commands/__init__.py), and what a parser shows of the methods, the body regions, the sweep and the live
mode (the backend registry, flows/facts.py, motion/regions.py, evaluation/sweep_limits.py, live/config.py) loads
without torch. Checked as a person runs them, with `python -X importtime`, whose report lists every module the process
imported."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


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


@pytest.mark.parametrize("command", sorted(_commands()))
def test_the_help_of_every_command_loads_no_torch(command):
    modules, out = imported("-m", "gesturelsm", command, "--help")
    assert f"gesturelsm {command}" in out
    assert "torch" not in modules


def test_the_help_shows_the_registry_read_without_torch():
    from gesturelsm.backends import SPECS
    from gesturelsm.motion.regions import GENERATED_REGIONS

    _, out = imported("-m", "gesturelsm", "edit", "--help")
    words = " ".join(out.split())
    assert all(key in words for key in SPECS) and ", ".join(GENERATED_REGIONS) in words


def test_the_settings_load_no_torch():
    modules, _ = imported("-c", "import gesturelsm.settings, gesturelsm.settings.arguments")
    assert "torch" not in modules
