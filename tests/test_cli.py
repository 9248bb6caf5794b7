"""The `gesturelsm` command registry (gesturelsm/cli.py): every subcommand module is imported when the command line
is, so a broken import fails loudly instead of leaving its command out; a problem the person can fix is one line and
exit status 2, anything else is a bug: "internal error", its traceback on stderr and exit status 1."""
from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

from gesturelsm import cli
from gesturelsm.commands import generate
from gesturelsm.errors import InputError

PACKAGE = Path(cli.__file__).resolve().parent
COMMANDS = {"align", "batch", "bench", "body", "data", "edit", "eval", "eval-tokenizer", "export", "genea", "generate",
            "import-reference", "live", "render", "serve", "stream", "study", "sweep", "train", "train-tokenizer",
            "transcribe"}


def _commands() -> set[str]:
    sub = next(a for a in cli.build_parser()._actions if a.__class__.__name__ == "_SubParsersAction")
    return set(sub.choices)


def _defines_add_parser(path: Path) -> bool:
    return any(isinstance(n, ast.FunctionDef) and n.name == "add_parser" for n in ast.parse(path.read_text()).body)


def test_every_subcommand_module_of_the_package_is_registered():
    """Every module of the package that defines `add_parser` (a subcommand) is in the registry."""
    found = {".".join(p.relative_to(PACKAGE.parent).with_suffix("").parts) for p in PACKAGE.rglob("*.py")
             if p != Path(cli.__file__).resolve() and _defines_add_parser(p)}
    assert {m.__name__ for m in cli.SUBCOMMANDS} == found
    assert _commands() == COMMANDS


def test_a_subcommand_that_cannot_be_imported_breaks_the_command_line():
    """With one subcommand's module unimportable (the ModuleNotFoundError a missing dependency or a moved module
    raises), importing the command line fails with that error: the command does not quietly vanish from
    `gesturelsm --help`."""
    code = ("import sys; sys.modules['gesturelsm.commands.live'] = None\n"
            "import gesturelsm.cli\n")
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                         cwd=PACKAGE.parent)
    assert run.returncode != 0
    assert "ModuleNotFoundError: import of gesturelsm.commands.live" in run.stderr, run.stderr[-2000:]


@pytest.fixture
def failing_generate(monkeypatch):
    """`gesturelsm generate` that raises what the test gives it."""
    def use(exc: BaseException):
        def run(args):
            raise exc
        monkeypatch.setattr(generate, "run_generate", run)
    return use


def test_a_problem_the_person_can_fix_is_one_line_with_status_2(failing_generate, capsys, tmp_path):
    failing_generate(InputError("the speech file is empty"))
    assert cli.main(["generate", str(tmp_path / "speech.wav"), "--out", str(tmp_path / "motion.npz")]) == 2
    err = capsys.readouterr().err
    assert err == "gesturelsm generate: error: the speech file is empty\n"


@pytest.mark.parametrize("exc", [ValueError("a bug's own message"), KeyError("a bug's own message"),
                                 FileNotFoundError("a bug's own message")])
def test_anything_else_is_an_internal_error_with_its_traceback_and_status_1(failing_generate, capsys, tmp_path, exc):
    failing_generate(exc)
    assert cli.main(["generate", str(tmp_path / "speech.wav"), "--out", str(tmp_path / "motion.npz")]) == 1
    err = capsys.readouterr().err
    assert err.startswith("gesturelsm generate: internal error, please report it")
    assert "Traceback (most recent call last)" in err and "a bug's own message" in err
