import json

from gesturelsm.cli import main
from gesturelsm.evaluation.bench import run_bench
from gesturelsm.evaluation.plot import quality_time_plot


def test_bench_rows_ratios_and_plot(eval_assets, tmp_path):
    rep = run_bench(eval_assets, presets=("shipped",), methods=["gesturelsm", "ddim"], steps=(1, 8), repeats=1,
                    long_seconds=6.0)
    rows = {(r["method"], r["steps"]): r for r in rep["rows"]}
    assert set(rows) == {("gesturelsm", 1), ("gesturelsm", 8), ("ddim", 1), ("ddim", 8)}
    for r in rows.values():
        assert r["aits"] > 0 and r["ms_per_step"] > 0 and r["rtf_10s"] > 0 and r["rtf_60s"] > 0
    steps_ratio = rep["ratios"]["shipped: GestureLSM 8 / 1 steps (AITS)"]     # the table's own numbers, not a
    assert steps_ratio == rows[("gesturelsm", 8)]["aits"] / rows[("gesturelsm", 1)]["aits"]  # timing verdict
    long_ratio = rep["ratios"]["shipped: ddim 8 steps / GestureLSM 8 steps (6 s of speech)"]
    assert long_ratio == rows[("ddim", 8)]["long_seconds"] / rows[("gesturelsm", 8)]["long_seconds"]
    assert rows[("gesturelsm", 8)]["rtf_60s"] == 6.0 / rows[("gesturelsm", 8)]["long_seconds"]
    ev = {"rows": [{"method": "gesturelsm", "steps": s, "heldout": {"fgd_k": 1.0 / s}} for s in (1, 8)]}
    png = quality_time_plot(rep, tmp_path / "q.png", ev)
    assert png.stat().st_size > 5000 and png.read_bytes()[:4] == b"\x89PNG"


def test_peak_rss_sees_an_allocation():
    # A fresh interpreter: in the test process an earlier test's freed (still resident) heap could serve the
    # allocation without raising RSS, which is correct behaviour but would make this check meaningless.
    import subprocess
    import sys

    code = ("import time, numpy as np\n"
            "from gesturelsm.evaluation.bench import PeakRSS\n"
            "with PeakRSS() as m:\n"
            "    a = np.ones(40 * 2 ** 20 // 8); a += 1; time.sleep(0.02)\n"
            "del a\n"
            "with PeakRSS() as idle:\n"
            "    time.sleep(0.02)\n"
            "print(m.megabytes, idle.megabytes)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    grown, idle = map(float, out)
    assert 30 < grown < 60          # the 40 MB array, not the interpreter
    assert idle < 5


def test_bench_cli(eval_assets, tmp_path):
    out = tmp_path / "b"
    ev = tmp_path / "eval.json"
    ev.write_text(json.dumps({"rows": [{"method": "gesturelsm", "steps": 1, "heldout": {"fgd_k": 2.0}},
                                       {"method": "gesturelsm", "steps": 2, "heldout": {"fgd_k": 1.0}}]}))
    rc = main(["bench", "--checkpoints", str(eval_assets), "--presets", "shipped", "--methods", "gesturelsm",
               "--steps", "1", "2", "--repeats", "1", "--long-seconds", "0", "--device", "cpu", "--quality", str(ev),
               "--out", str(out)])
    assert rc == 0
    rep = json.loads((out / "bench.json").read_text())
    assert [r["steps"] for r in rep["rows"]] == [1, 2]
    from gesturelsm.evaluation.timing import hardware_name

    assert rep["hardware"] == hardware_name("cpu") and {r["hardware"] for r in rep["rows"]} == {rep["hardware"]}
    md = (out / "bench.md").read_text()
    assert f"| {rep['hardware']} |" in md                                # beside every figure
    assert "| shipped | GestureLSM | 1 |" in md and "0.015" in md       # paper's 1-step AITS beside ours
    assert (out / "bench.png").exists()

    again = tmp_path / "b2"
    assert main(["bench", "--from-json", str(out / "bench.json"), "--out", str(again)]) == 0
    assert (again / "bench.md").read_text() == md and (again / "bench.png").exists()
