"""The package's import graph flows downward only: a module may import from its own part of the package or
from a lower floor, never from the same floor's other parts (sideways) or from above. Floors, lowest first;
a part is a top-level module or subpackage of gesturelsm, or one module of a subpackage that spans floors
(SPLIT: serve's request rules and upload sniffing sit on the lowest floor, its service above the pipeline).
And no module imports itself through others: the module graph has no circle, within a part either.
Imports inside functions count too."""
from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "gesturelsm"
FLOORS: list[set[str]] = [
    {"constants", "errors", "serve.limits", "serve.uploads", "safe_load",  # conventions, the error family, request
     "presentation"},                                          # limits, upload sniffing, safe loading, methods'
                                                               # labels and colours
    {"motion", "audio", "checkpoint", "flows", "kernels"},     # motion data, speech loading, files, the methods,
                                                               # fp32 linear layers through oneDNN
    {"body", "features", "align", "metrics"},                  # body models, speech features, word timings
    {"asr"},                                                   # speech recognition (times words with align)
    {"data"},                                                  # datasets (BEAT2 layout, TextGrids via align)
    {"retarget"},                                              # motion onto characters (their skeletons and meshes)
    {"tokenizer", "render"},                                   # RVQ-VAEs; offscreen video (the mannequin or a character)
    {"generator", "export", "reference"},                                   # the denoisers (ours; the authors', reference/); BVH / GLB / keypoints (render's camera)
    {"backends"},                                              # every method (ours, the authors') behind one call
    {"pipeline"},                                              # speech -> motion, one request flow
    {"serve", "study", "evaluation", "pipeline_cli", "edit_cli",  # what uses the pipeline (serve: one web request,
     "live"},                                                  # its checks and files; live: streaming; the generate
                                                               # and edit commands)
    {"webapp"},                                                # the Gradio page over serve and live
    {"cli"},                                                   # the command line registry
    {"__main__"},                                              # python -m gesturelsm
]
FLOOR = {part: i for i, parts in enumerate(FLOORS) for part in parts}
SPLIT = {p.split(".")[0] for p in FLOOR if "." in p}          # subpackages whose modules have floors of their own


def part_of(module: str) -> str:
    """'gesturelsm.render.frames' -> 'render'; 'gesturelsm.serve.limits' -> 'serve.limits' (a split subpackage's
    module with a floor of its own), 'gesturelsm.serve.service' -> 'serve'; 'gesturelsm' (the package's __init__)
    -> ''."""
    parts = module.split(".")
    if len(parts) > 2 and parts[1] in SPLIT and f"{parts[1]}.{parts[2]}" in FLOOR:
        return f"{parts[1]}.{parts[2]}"
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
    assert all((PACKAGE / f"{p.replace('.', '/')}.py").is_file() for p in FLOOR if "." in p)


def module_graph(root: Path = PACKAGE) -> dict[str, set[str]]:
    """module -> the package's modules it imports ('gesturelsm.x.y'; a package is its __init__, named as the
    package). `from .x import name` counts as importing x, and x.name when that is a module of its own."""
    modules = {".".join(p.relative_to(root.parent).with_suffix("").parts).removesuffix(".__init__"): p
               for p in root.rglob("*.py")}
    graph = {}
    for mod, path in modules.items():
        targets = set()
        for _line, target in imports(path, root):
            while target not in modules and "." in target:    # `from .m import name`: the module m
                target = target.rsplit(".", 1)[0]
            if target in modules and target != mod:
                targets.add(target)
        graph[mod] = targets
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every strongly connected group of more than one module (Tarjan), each sorted: a circle of imports."""
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10 * len(graph) + 100))
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_module_imports_itself_through_others():
    """A package's __init__ that re-exports its modules is not a circle as long as those modules import their
    siblings directly, not through the package."""
    assert circles(module_graph()) == []


def package(root: Path, files: dict[str, str]) -> Path:
    """A throwaway gesturelsm package under `root`: {relative path: source}, with the __init__ files it needs."""
    pkg = root / "gesturelsm"
    for rel, text in {"__init__.py": "", **files}.items():
        (pkg / rel).parent.mkdir(parents=True, exist_ok=True)
        (pkg / rel).write_text(text)
        if (pkg / rel).parent != pkg:
            (pkg / rel).parent.joinpath("__init__.py").touch()
    return pkg


def test_a_circle_is_caught(tmp_path):
    pkg = package(tmp_path, {"webapp/a.py": "from .b import x\n",
                             "webapp/b.py": "def f():\n    from . import a\n",     # inside a function counts too
                             "webapp/c.py": "from .a import y\n"})
    assert circles(module_graph(pkg)) == [["gesturelsm.webapp.a", "gesturelsm.webapp.b"]]


def test_imports_only_go_down():
    assert violations() == []


def test_an_upward_import_is_caught(tmp_path):
    """The checker itself: a copy of one part that imports from above is reported."""
    pkg = package(tmp_path, {"motion/x.py": "from ..pipeline import GesturePipeline\nfrom . import sequence\n",
                             "flows.py": "from .motion import x\n"})                 # sideways: same floor
    found = violations(pkg)
    assert any("upward import motion -> pipeline" in v for v in found), found
    assert any("sideways import flows -> motion" in v for v in found), found
    assert len(found) == 2, found


@pytest.mark.parametrize("module, part", [("gesturelsm.render.frames", "render"), ("gesturelsm", ""),
                                          ("gesturelsm.pipeline", "pipeline"),
                                          ("gesturelsm.serve.limits", "serve.limits"),
                                          ("gesturelsm.serve.service", "serve"), ("gesturelsm.serve", "serve")])
def test_part_of(module, part):
    assert part_of(module) == part
