"""The package's import graph flows downward only: a module may import from its own part of the package or
from a lower floor, never from the same floor's other parts (sideways) or from above. Floors, lowest first; a part
is a top-level module or subpackage of gesturelsm, and every module of a subpackage belongs to its part (no part
spans floors). No import circle, neither between files nor between parts: when a part imports another, nothing of
the other imports it back, directly or through others. Imports inside functions count too. No file over
MAX_FILE_LINES lines and no function over MAX_FUNCTION_LINES."""
from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "gesturelsm"
FLOORS: list[set[str]] = [
    {"constants", "errors", "lazy", "memo"},                   # conventions, the error family, names on first use,
                                                               # a memo of recent results
    {"safe_load", "progress", "request_files"},                # safe loading; progress reports (spans, stages,
                                                               # the command line's renderer); the server's folder
                                                               # and file names
    {"motion", "audio", "checkpoint", "flows", "kernels",      # motion data, speech input (what a file is, reading
     "cluster"},                                               # it), files, the methods, fast CPU kernels; units
                                                               # of work here or as Ray tasks (no Ray until asked)
    {"body", "features", "align", "metrics"},                  # body models, speech features, word timings
    {"asr", "grounding"},                                      # speech recognition (times words with align); feet on
                                                               # the floor (leg IK on a body's or a rig's skeleton)
    {"data"},                                                  # datasets (BEAT2 layout, TextGrids via align)
    {"retarget"},                                              # motion onto characters (their skeletons and meshes)
    {"tokenizer", "render"},                                   # RVQ-VAEs; offscreen video (the mannequin, a character)
    {"generator", "export", "reference"},                      # the denoisers (ours; the authors', reference/);
                                                               # BVH / GLB / keypoints (render's camera)
    {"backends"},                                              # every method (ours, the authors') behind one call,
                                                               # each described once (its spec)
    {"settings"},                                              # one generation's settings, defaults, validator
    {"pipelined"},                                             # speech preparation pipelined with generation
    {"streaming"},                                             # motion as it is made: per method, per window
    {"pipeline"},                                              # speech -> motion, one request flow
    {"study", "evaluation", "live", "genea"},                  # what uses the pipeline (live: streaming; GENEA
                                                               # submissions)
    {"serve"},                                                 # one web request: checks, files, its sweep, edits
    {"webapp"},                                                # the Gradio page over serve and live
    {"commands"},                                              # the subcommands, one module each
    {"cli"},                                                   # the command line registry
    {"__main__"},                                              # python -m gesturelsm
]
FLOOR = {part: i for i, parts in enumerate(FLOORS) for part in parts}
MAX_FILE_LINES = 400
MAX_FUNCTION_LINES = 80
# (file relative to the package, or "file:function") -> why it may be longer; empty: every file and function fits
LONGER: dict[str, str] = {}


def part_of(module: str) -> str:
    """'gesturelsm.render.frames' -> 'render'; 'gesturelsm.pipeline' -> 'pipeline'; 'gesturelsm' (the package's
    __init__) -> ''."""
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


def part_graph(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    """The module graph with each part (a top-level module, or a subpackage with all its modules) as one node;
    the package's own __init__ is the node ''."""
    parts: dict[str, set[str]] = {}
    for mod, targets in graph.items():
        parts.setdefault(part_of(mod), set()).update(part_of(t) for t in targets if part_of(t) != part_of(mod))
    return parts


def test_no_part_imports_itself_through_others():
    """Counting each subpackage (and each top-level module) as one unit: when one imports another, nothing of the
    other imports it back, directly or through other parts."""
    assert circles(part_graph(module_graph())) == []


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


def test_a_circle_between_parts_is_caught(tmp_path):
    """Files without a circle of their own: audio.loading -> serve.uploads -> webapp.ui -> audio.containers."""
    pkg = package(tmp_path, {"audio/loading.py": "from ..serve import uploads\n",
                             "serve/uploads.py": "from ..webapp.ui import page\n",
                             "webapp/ui.py": "from ..audio.containers import sniff\n",
                             "audio/containers.py": "", "motion/x.py": "from ..audio import loading\n"})
    assert circles(module_graph(pkg)) == []
    assert circles(part_graph(module_graph(pkg))) == [["audio", "serve", "webapp"]]


def _too_long(root: Path = PACKAGE) -> list[str]:
    """Files over MAX_FILE_LINES lines and functions (methods too) over MAX_FUNCTION_LINES, not in LONGER."""
    found = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root).as_posix()
        text = path.read_text()
        if len(text.splitlines()) > MAX_FILE_LINES and rel not in LONGER:
            found.append(f"{rel}: {len(text.splitlines())} lines")
        for node in ast.walk(ast.parse(text, str(path))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION_LINES and f"{rel}:{node.name}" not in LONGER:
                    found.append(f"{rel}:{node.lineno}: {node.name}, {n} lines")
    return found


def test_no_file_or_function_is_too_long():
    assert _too_long() == []
    assert all(why.strip() for why in LONGER.values()), "every exception says why"


def test_a_long_function_is_caught(tmp_path):
    body = "".join(f"    x{i} = {i}\n" for i in range(MAX_FUNCTION_LINES))
    pkg = package(tmp_path, {"motion/x.py": f"def long():\n{body}\n\ndef short():\n    return 1\n"})
    assert _too_long(pkg) == [f"motion/x.py:1: long, {MAX_FUNCTION_LINES + 1} lines"]


def private_imports(root: Path = PACKAGE) -> list[str]:
    """`from <a module of the package> import _name`: a name its module keeps to itself, taken by another module."""
    found = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root.parent)
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom) and (node.level or (node.module or "").startswith("gesturelsm")):
                found += [f"{rel}:{node.lineno}: {'.' * node.level}{node.module or ''} import {a.name}"
                          for a in node.names if a.name.startswith("_") and not a.name.startswith("__")]
    return found


def test_no_module_takes_another_modules_private_names():
    assert private_imports() == []


def test_a_private_import_is_caught(tmp_path):
    pkg = package(tmp_path, {"export/glb.py": "class _Builder: ...\n", "export/rig.py": "from .glb import _Builder\n",
                             "export/npz.py": "from .glb import __doc__\n"})
    assert private_imports(pkg) == ["gesturelsm/export/rig.py:1: .glb import _Builder"]


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
                                          ("gesturelsm.serve.limits", "serve"),
                                          ("gesturelsm.audio.containers", "audio"),
                                          ("gesturelsm.serve.service", "serve"), ("gesturelsm.serve", "serve")])
def test_part_of(module, part):
    assert part_of(module) == part
