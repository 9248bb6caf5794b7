"""`gesturelsm generate` without a transcript against the same command given the words' timings. Markdown out.

    NUMBA_CACHE_DIR=.venv/numba-cache .venv/bin/python benchmarks/cli_words.py [--take 2_scott_0_3_3] [--rounds 3]

1. The command line, each run a fresh process (nothing remembered between runs), interleaved round by round:
   `gesturelsm generate TAKE.wav --textgrid TAKE.TextGrid` (the words' timings given) and `gesturelsm generate
   TAKE.wav` (the words recognised, window by window while the motion is generated). Per run: the command's wall
   time, the end to end it reports (reading the speech to writing the motion, models loaded) and what it says of the
   transcription hidden under generation. The issue's target: medians at most 1.3x.
2. In one process (models loaded once, the recogniser's memory cleared before every run), the same speech three ways,
   interleaved: the words given (TextGrid), recognised first and then generated (one-shot, one thread), and recognised
   on a thread while generated (pipelined): whether the two stages on two threads are faster on this machine.
The machine may be shared with other work: wall-clock figures are indicative.
"""
from __future__ import annotations

from _harness import BEAT2, REPO, Rows

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(REPO))


def run_cli(wav: Path, textgrid: Path | None, out: Path) -> tuple[float, float, str]:
    """(wall s, reported end-to-end s, the hidden-transcription line or "")."""
    cmd = [sys.executable, "-m", "gesturelsm", "generate", str(wav), "--out", str(out)]
    cmd += ["--textgrid", str(textgrid)] if textgrid else []
    env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    t0 = time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=REPO)
    wall = time.perf_counter() - t0
    if res.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{res.stderr[-2000:]}")
    e2e = float(re.search(r"x end to end \(([\d.]+) s", res.stdout).group(1))
    hidden = next((line for line in res.stdout.splitlines() if line.startswith("transcription ")), "")
    return wall, e2e, hidden


def cli(wav: Path, textgrid: Path, rounds: int) -> list[str]:
    runs: dict[str, list[tuple[float, float, str]]] = {"words given (--textgrid)": [], "words recognised": []}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(rounds):
            for name, tg in zip(runs, (textgrid, None)):
                runs[name].append(run_cli(wav, tg, Path(tmp) / f"{r}.npz"))
                print(f"round {r + 1} {name}: {runs[name][-1][:2]}", file=sys.stderr)
    rows = Rows(["gesturelsm generate", "wall s (runs)", "median wall s", "median end to end s", "hidden (last run)"])
    for name, rs in runs.items():
        rows.add(name, ", ".join(f"{w:.1f}" for w, _, _ in rs), f"{statistics.median(w for w, _, _ in rs):.1f}",
                 f"{statistics.median(e for _, e, _ in rs):.1f}", rs[-1][2].split(" (recognised")[0] or "-")
    a, b = (runs[k] for k in runs)
    ratio_wall = statistics.median(w for w, _, _ in b) / statistics.median(w for w, _, _ in a)
    ratio_e2e = statistics.median(e for _, e, _ in b) / statistics.median(e for _, e, _ in a)
    return [rows.markdown(), "", f"recognised / given: {ratio_wall:.2f}x wall (whole command), {ratio_e2e:.2f}x end to "
            "end (as reported: models loaded)"]


def in_process(wav: Path, textgrid: Path, rounds: int) -> list[str]:
    from gesturelsm.align import read_words
    from gesturelsm.asr.source import RECENT
    from gesturelsm.audio import load_audio
    from gesturelsm.pipeline import GesturePipeline

    pipe = GesturePipeline.from_pretrained(methods=["gesturelsm"])
    y, words = load_audio(wav), read_words(textgrid)
    ways = {"words given": lambda: pipe.generate(pipe.prepare_speech(y, words=words), output="raw"),
            "one-shot (recognise, then generate)": lambda: pipe.generate(pipe.prepare_speech(y), output="raw"),
            "pipelined (two threads)": lambda: pipe.generate(y, output="raw")}
    times: dict[str, list[float]] = {k: [] for k in ways}
    hidden: list[float] = []
    pipe.generate(y[:16000 * 5], transcribe=False, output="raw")                      # warm
    for _ in range(rounds):
        for name, fn in ways.items():
            RECENT.clear()
            t0 = time.perf_counter()
            res = fn()
            times[name].append(time.perf_counter() - t0)
            if "pipelined" in name:
                hidden.append(res.timings.get("transcription hidden", 0.0) / max(res.timings["transcription"], 1e-9))
    rows = Rows(["in one process", "s (runs)", "median s"])
    for name, ts in times.items():
        rows.add(name, ", ".join(f"{t:.1f}" for t in ts), f"{statistics.median(ts):.1f}")
    return [rows.markdown(), "", f"share of the transcription hidden under generation (pipelined, median): "
            f"{100 * statistics.median(hidden):.0f} %"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=BEAT2)
    ap.add_argument("--take", default="2_scott_0_3_3", help="a take with wave16k/ and textgrid/ (60-80 s)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--skip-cli", action="store_true")
    ap.add_argument("--skip-in-process", action="store_true")
    args = ap.parse_args()
    wav, tg = args.data / "wave16k" / f"{args.take}.wav", args.data / "textgrid" / f"{args.take}.TextGrid"
    if not (wav.is_file() and tg.is_file()):
        print(f"no take {args.take} with speech and TextGrid at {args.data}", file=sys.stderr)
        return 2
    print(f"{args.take}, {args.rounds} rounds, interleaved; load average before: {os.getloadavg()[0]:.1f}\n")
    if not args.skip_cli:
        print("\n".join(cli(wav, tg, args.rounds)) + "\n")
    if not args.skip_in_process:
        print("\n".join(in_process(wav, tg, args.rounds)))
    print(f"\nload average after: {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
