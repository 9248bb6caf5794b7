"""benchmarks/_harness.py: the data path (GESTURELSM_SHARED, else ../shared), the thread count, a timer with medians and
one row format; and every benchmark script runs through it (takes the shared data and its thread count from it)."""
from __future__ import annotations

import ast
import importlib.util
import json
import statistics
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
BENCHMARKS = REPO / "benchmarks"


def _harness(monkeypatch, shared: str | None):
    if shared is None:
        monkeypatch.delenv("GESTURELSM_SHARED", raising=False)
    else:
        monkeypatch.setenv("GESTURELSM_SHARED", shared)
    spec = importlib.util.spec_from_file_location("_harness_under_test", BENCHMARKS / "_harness.py")
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, module)
    spec.loader.exec_module(module)
    return module


def test_the_data_path(monkeypatch, tmp_path):
    h = _harness(monkeypatch, str(tmp_path))
    assert h.BEAT2 == tmp_path / "data" / "beat2" and h.CHARACTERS == tmp_path / "assets" / "characters"
    assert h.take_wav("2_scott_0_2_2") == tmp_path / "data" / "beat2" / "wave16k" / "2_scott_0_2_2.wav"
    assert _harness(monkeypatch, None).SHARED == REPO.parent / "shared"


def test_timer_and_rows(monkeypatch):
    h = _harness(monkeypatch, None)
    calls = []
    t = h.timed(lambda: calls.append(1), repeats=5, warmup=2)
    assert len(calls) == 7 and len(t.runs) == 5
    assert t.median == statistics.median(t.runs) and t.min == min(t.runs)
    rows = h.Rows(["setting", "median s"])
    rows.add("8 steps", "0.41")
    assert rows.markdown().splitlines() == ["| setting | median s |", "|---|---|", "| 8 steps | 0.41 |"]
    assert json.loads(rows.json()) == [{"setting": "8 steps", "median s": "0.41"}]


def test_threads(monkeypatch):
    import torch

    h = _harness(monkeypatch, None)
    before = torch.get_num_threads()
    try:
        assert h.set_threads(1) == 1 and torch.get_num_threads() == 1
    finally:
        torch.set_num_threads(before)


def test_every_script_takes_the_data_path_and_threads_from_the_harness():
    for path in sorted(BENCHMARKS.glob("*.py")):
        if path.name == "_harness.py":
            continue
        tree = ast.parse(path.read_text())
        nodes = list(ast.walk(tree))
        assert not any(isinstance(n, ast.Constant) and n.value == "shared" for n in nodes), \
            f"{path.name} builds the shared-data path itself"
        assert not any(isinstance(n, ast.Attribute) and n.attr == "set_num_threads" for n in nodes), \
            f"{path.name} sets torch's threads itself"
        used = {n.id for n in nodes if isinstance(n, ast.Name)} & {"BEAT2", "SHARED", "CHARACTERS", "set_threads"}
        known = {a.name for n in nodes if isinstance(n, ast.ImportFrom) for a in n.names}        # _harness's, or
        known |= {t.id for n in tree.body if isinstance(n, ast.Assign) for t in n.targets if isinstance(t, ast.Name)}
        assert used <= known, (path.name, used - known)                     # another script's, or its own name


def test_rows_as_they_come_stopwatch_and_json(monkeypatch, tmp_path):
    h = _harness(monkeypatch, None)
    rows = h.Rows(["case", "seconds"])
    rows.add("a", "0.10")
    assert rows.header() == "| case | seconds |\n|---|---|" and rows.last() == "| a | 0.10 |"
    rows.add("b", 2)
    assert rows.markdown() == rows.header() + "\n| a | 0.10 |\n| b | 2 |"
    with h.Stopwatch() as sw:
        assert sw.elapsed >= 0
    assert sw.seconds >= 0
    h.save_json(tmp_path / "one.json", rows)
    assert json.loads((tmp_path / "one.json").read_text()) == [{"case": "a", "seconds": "0.10"},
                                                               {"case": "b", "seconds": "2"}]
    h.save_json(tmp_path / "two.json", {"first": rows, "second": h.Rows(["x"])})
    assert json.loads((tmp_path / "two.json").read_text()) == {"first": rows.records(), "second": []}
    h.save_json(None, rows)                                               # no --json: nothing written


SCRIPTS = [p.name for p in sorted(BENCHMARKS.glob("*.py")) if not p.name.startswith("_")]


@pytest.mark.parametrize("name", SCRIPTS)
def test_every_script_runs_through_the_harness(name):
    tree = ast.parse((BENCHMARKS / name).read_text())
    nodes = list(ast.walk(tree))
    assert any(isinstance(n, ast.ImportFrom) and n.module == "_harness" for n in nodes), f"{name} skips _harness"


def test_player_latency_keeps_its_flags_and_its_table(monkeypatch, capsys):
    """Other docs quote its command lines and columns: the flags stay, and a row has one cell per column."""
    monkeypatch.setattr(sys, "path", [str(BENCHMARKS)] + sys.path)               # as `python benchmarks/NAME.py`
    spec = importlib.util.spec_from_file_location("_player_latency_under_test", BENCHMARKS / "player_latency.py")
    m = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(m)
    with pytest.raises(SystemExit):
        m.main(["--help"])
    shown = capsys.readouterr().out
    for flag in ("--seconds", "--methods", "--think-s", "--repeat", "--vs", "--quick", "--without-ahead", "--new-seed",
                 "--character", "--chromium", "--json"):
        assert flag in shown, flag
    run = {"play": 1.0, "all": 1.5, "marks": {"payload": 0.2, "given": 500.0}, "drawn2": 30, "fps_render": 20.0,
           "mp4": 9.0, "fps_idle": 30.0, "prof": None, "scrub": 0, "again": 1.1, "again_rendering": 1.2,
           "rendering": True}
    quick = m.Rows(m.HEADER)
    quick.add(*m.cells(10.0, 1, "this checkout", "mannequin", [run, run], True))
    assert quick.last() == "| 10.0 s | 1 | this checkout | mannequin | **1.00** (1.00-1.00) | 1.50 | 30 | 0.20 | 0.70 |"
    older = {**run, "marks": {"payload": 0.2}}                    # a player bundle without the `given` mark (--vs)
    quick.add(*m.cells(10.0, 1, "before (--vs)", "mannequin", [older], True))
    assert quick.last().endswith("| 0.20 | n/a |")
    full = m.Rows(m.HEADER + m.FULL)
    full.add(*m.cells(10.0, 1, "this checkout", "mannequin", [run], False))
    assert full.last().endswith("| 20.0 | 9.0 | 30.0 | n/a | 0 | 1.10 | 1.20 (1/1) |")
