"""The package's import graph flows downward only: a module may import from its own part of the package or
from a lower floor, never from the same floor's other parts (sideways) or from above. Floors, lowest first;
a part is a top-level module or subpackage of gesturelsm. Imports inside functions count too."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "gesturelsm"
FLOORS: list[set[str]] = [
    {"constants", "errors", "limits", "uploads", "safe_load"},  # conventions, the error family, request limits,
                                                               # upload format sniffing, tensors-only loading
    {"motion", "audio", "checkpoint", "flows", "kernels"},     # motion data, speech loading, files, the methods,
                                                               # fp32 linear layers through oneDNN
    {"body", "features", "align", "metrics"},                  # body models, speech features, word timings
    {"asr"},                                                   # speech recognition (times words with align)
    {"data"},                                                  # datasets (BEAT2 layout, TextGrids via align)
    {"tokenizer", "render", "retarget"},                       # RVQ-VAEs; offscreen video; motion onto characters
    {"generator", "export", "reference"},                                   # the denoisers (ours; the authors', reference/); BVH / GLB / keypoints (render's camera)
    {"pipeline"},                                              # speech -> motion, one request flow
    {"app_checks"},                                            # a web request's fields checked before any work
    {"app_service", "study", "evaluation", "pipeline_cli", "live"},   # what uses the pipeline (live: streaming)
    {"cli"},                                                   # the command line registry
    {"__main__"},                                              # python -m gesturelsm
]
FLOOR = {part: i for i, parts in enumerate(FLOORS) for part in parts}


def part_of(module: str) -> str:
    """'gesturelsm.render.frames' -> 'render'; 'gesturelsm' (the package's __init__) -> ''."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def imports(path: Path, root: Path = PACKAGE) -> list[tuple[int, str]]:
    """(line, absolute module) of every project import in the file, including `from . import x` names."""
    rel = path.relative_to(root.parent).with_suffix("")
    pkg = list(rel.parts if path.name == "__init__.py" else rel.parts[:-1])
    if path.name == "__init__.py":
        pkg = pkg[:-1] if pkg[-1] == "__init__" else pkg
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom):
            base = ".".join(pkg[:len(pkg) - node.level + 1]) if node.level else ""
            mod = ".".join(p for p in (base, node.module or "") if p)
            if node.module is None:
                out += [(node.lineno, f"{mod}.{a.name}") for a in node.names]
            else:
                out.append((node.lineno, mod))
        elif isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
    return [(line, m) for line, m in out if m == "gesturelsm" or m.startswith("gesturelsm.")]


def violations(root: Path = PACKAGE) -> list[str]:
    bad = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root.parent)
        me = part_of(".".join(rel.with_suffix("").parts))
        if me == "__init__":                                   # the package's own __init__: exports only
            continue
        for line, target in imports(path, root):
            other = part_of(target)
            if other == me or other in ("", "__init__"):
                continue
            if me not in FLOOR or other not in FLOOR:
                bad.append(f"{rel}:{line}: {me or 'gesturelsm'} -> {other}: a part with no floor (add it to FLOORS)")
            elif FLOOR[other] >= FLOOR[me]:
                kind = "sideways" if FLOOR[other] == FLOOR[me] else "upward"
                bad.append(f"{rel}:{line}: {kind} import {me} -> {other}")
    return bad


def test_every_part_of_the_package_has_a_floor():
    parts = {p.stem if p.is_file() else p.name for p in PACKAGE.iterdir()
             if (p.suffix == ".py" and p.stem != "__init__") or (p / "__init__.py").exists()}
    assert parts <= set(FLOOR), f"parts without a floor: {sorted(parts - set(FLOOR))}"


def test_imports_only_go_down():
    assert violations() == []


def test_an_upward_import_is_caught(tmp_path):
    """The checker itself: a copy of one part that imports from above is reported."""
    pkg = tmp_path / "gesturelsm"
    (pkg / "motion").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "motion" / "__init__.py").write_text("")
    (pkg / "motion" / "x.py").write_text("from ..pipeline import GesturePipeline\nfrom . import sequence\n")
    (pkg / "flows.py").write_text("from .motion import x\n")                    # sideways: same floor
    found = violations(pkg)
    assert any("upward import motion -> pipeline" in v for v in found), found
    assert any("sideways import flows -> motion" in v for v in found), found
    assert len(found) == 2, found


@pytest.mark.parametrize("module, part", [("gesturelsm.render.frames", "render"), ("gesturelsm", ""),
                                          ("gesturelsm.pipeline", "pipeline")])
def test_part_of(module, part):
    assert part_of(module) == part
