"""The wheel: one top-level package, `gesturelsm` (no `app`, which would collide with any other project's `app`),
the web page inside it with its examples, the shipped assets, and the `gesturelsm` command whose `serve`
subcommand starts the demo. Built from a copy of the checkout's packaging inputs, so the checkout gets no
build/ or egg-info folders."""
from __future__ import annotations

import configparser
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def wheel(built_wheel) -> Path:
    return built_wheel


def test_the_wheel_has_one_top_level_package_and_no_app(wheel):
    z = zipfile.ZipFile(wheel)
    tops = {n.split("/")[0] for n in z.namelist() if not n.split("/")[0].endswith((".dist-info", ".data"))}
    assert tops == {"gesturelsm"}, tops
    for listed in (n for n in z.namelist() if n.endswith(".dist-info/top_level.txt")):
        assert z.read(listed).decode().split() == ["gesturelsm"]


def test_the_wheel_carries_the_page_its_examples_and_the_shipped_assets(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    for path in ("gesturelsm/webapp/ui.py", "gesturelsm/commands/serve.py", "gesturelsm/serve/service.py",
                 "gesturelsm/webapp/examples/examples.json", "gesturelsm/webapp/examples/hello.wav",
                 "gesturelsm/_assets/MODEL_CARD.md", "gesturelsm/_assets/generator/gesturelsm.safetensors",
                 "gesturelsm/_assets/body/SMPLX_MANNEQUIN.npz"):
        assert path in names, path
    built = (REPO / "gesturelsm" / "webapp" / "player" / "dist" / "player.js").is_file()
    player = sorted(n for n in names if n.startswith("gesturelsm/webapp/player/"))
    expected = ["gesturelsm/webapp/player/__init__.py", "gesturelsm/webapp/player/component.py"]
    assert player == sorted(expected + ["gesturelsm/webapp/player/dist/player.js"] * built)   # no sources, no npm


def test_the_wheel_installs_the_gesturelsm_command_with_serve(wheel):
    z = zipfile.ZipFile(wheel)
    entry = next(n for n in z.namelist() if n.endswith(".dist-info/entry_points.txt"))
    points = configparser.ConfigParser()
    points.read_string(z.read(entry).decode())
    assert dict(points["console_scripts"]) == {"gesturelsm": "gesturelsm.cli:main"}


def test_gesturelsm_serve_has_the_flags_of_python_m_app():
    from gesturelsm.cli import build_parser
    from gesturelsm.commands.serve import build_parser as app_parser

    sub = next(a for a in build_parser()._actions if a.__class__.__name__ == "_SubParsersAction")
    serve = sub.choices["serve"]
    def flags(p):
        return sorted((a.option_strings[-1], a.default, a.type) for a in p._actions if a.option_strings)

    assert flags(serve) == flags(app_parser()) and ("--port", 7860, int) in flags(serve)
    assert serve.prog == "gesturelsm serve" and serve.description.startswith("`gesturelsm serve`: start the web demo")


def _requirements_txt() -> dict:
    from packaging.requirements import Requirement

    lines = (line.split("#")[0].strip() for line in (REPO / "requirements.txt").read_text().splitlines())
    return {r.name.lower(): r for r in map(Requirement, filter(None, lines))}


def _declared() -> tuple[list, dict]:
    import tomllib

    from packaging.requirements import Requirement

    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    extras = {k: [Requirement(s) for s in v] for k, v in project["optional-dependencies"].items()}
    return [Requirement(s) for s in project["dependencies"]], extras


def test_the_declared_dependencies_are_requirements_txt():
    """`pip install gesturelsm[demo,cluster,study,dev]` asks for what `make setup` installs, by the same names and
    versions (torch by version: scripts/setup.sh installs its CPU build); nothing declared that make setup lacks."""
    pinned = _requirements_txt()
    core, extras = _declared()
    assert set(extras) == {"demo", "cluster", "study", "dev"}
    declared = {}
    for r in core + [r for group in extras.values() for r in group if r.name != "gesturelsm"]:
        assert r.name.lower() not in declared, f"{r.name} declared twice"
        declared[r.name.lower()] = r
    assert sorted(declared) == sorted(pinned)
    for name, r in declared.items():
        want = pinned[name]
        spec = str(want.specifier).replace("+cpu", "") if name == "torch" else str(want.specifier)
        assert (str(r.specifier), r.extras) == (spec, want.extras), name
    assert str(pinned["torch"].specifier) == "==2.13.0+cpu"                    # the CPU build, never CUDA
    assert {r.name: r.extras for r in extras["dev"] if r.name == "gesturelsm"} == {
        "gesturelsm": {"demo", "cluster", "study"}}                          # [dev] is everything
    assert not {"gradio", "ray", "sqlalchemy", "playwright"} & {r.name.lower() for r in core}   # optional, not core


def test_setup_installs_requirements_txt_and_the_cpu_torch():
    setup = (REPO / "scripts" / "setup.sh").read_text()
    assert '-r requirements.txt' in setup and '"torch==2.13.0+cpu"' in setup
