"""How fast, and in how much memory, hostile uploads are refused. Each case runs in a fresh
Python process (so the peak RSS is that case alone) and prints one markdown row.

    PYTHONPATH=.:tests .venv/bin/python benchmarks/hostile_uploads.py [--hours 10] [--max-seconds 300] [--json FILE]

Cases: a FLAC of N hours of silence whose header states its length / says "unknown length" (decoding
then stops at the limit); an HLS playlist naming a server file; a TextGrid of 200k intervals and a
transcript of 50k words for 2 s of speech (the checks the app service runs before any work). The
baseline row reads the same TextGrid with no limit, to show what the size cap saves.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from _harness import REPO, Rows, json_flag, save_json

CASE = r"""
import json, sys


def peak_mb():
    # VmHWM: this process's own peak resident memory. (ru_maxrss is not: Linux keeps it across fork + exec, so a
    # child of a big pytest process reports the parent's size.)
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return float("nan")


from pathlib import Path
from _harness import Stopwatch
from gesturelsm.serve.checks import textgrid_words
from gesturelsm.align.textgrid import read_result
from gesturelsm.audio import load_audio
from gesturelsm.serve.limits import transcript_problems
kind, path, max_s = sys.argv[1], sys.argv[2], float(sys.argv[3])
with Stopwatch() as clock:                   # imports are not timed
    try:
        if kind == "audio":
            load_audio(path, max_seconds=max_s)
        elif kind == "textgrid":
            words, problems, _ = textgrid_words(path, 2.0)
            if problems:
                raise ValueError(problems[0])
        elif kind == "textgrid-unbounded":
            read_result(path)
        elif kind == "transcript":
            problems = transcript_problems(Path(path).read_text(), 2.0)
            if problems:
                raise ValueError(problems[0])
        outcome = "accepted"
    except Exception as exc:
        outcome = f"refused ({type(exc).__name__})"
print(json.dumps({"outcome": outcome, "seconds": clock.seconds,
                  "peak_mb": peak_mb()}))
"""


def run_case(kind: str, path: Path, max_seconds: float) -> dict:
    env = {"PYTHONPATH": os.pathsep.join([str(REPO), str(REPO / "benchmarks")]), "PATH": "/usr/bin:/bin"}
    proc = subprocess.run([sys.executable, "-c", CASE, kind, str(path), str(max_seconds)], capture_output=True,
                          text=True, cwd=REPO, env=env, timeout=900)
    if proc.returncode:
        raise RuntimeError(proc.stderr)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--hours", type=float, default=10.0)
    p.add_argument("--max-seconds", type=float, default=300.0)
    json_flag(p)
    args = p.parse_args(argv)
    sys.path.insert(0, str(REPO / "tests"))
    from _hostile import playlist_naming, silent_flac

    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        h = args.hours
        secret = silent_flac(d / "secret.flac", 3.0)
        tg = d / "big.TextGrid"
        lines = ['File type = "ooTextFile"', 'Object class = "TextGrid"', "", "0", "2", "<exists>", "1",
                 '"IntervalTier"', '"words"', "0", "2", "200000"]
        for i in range(200_000):
            lines += [repr(i * 1e-5), repr((i + 1) * 1e-5), '"w"']
        tg.write_text("\n".join(lines) + "\n")
        words = d / "words.txt"
        words.write_text("word " * 50_000)
        cases = [
            (f"FLAC, {h:g} h of silence, length in header", "audio", silent_flac(d / "a.flac", h * 3600)),
            (f"FLAC, {h:g} h of silence, 'unknown length' header", "audio",
             silent_flac(d / "b.flac", h * 3600, stated_samples=0)),
            ("HLS playlist naming a server file", "audio", playlist_naming(d / "p.m3u8", secret)),
            ("TextGrid, 200k intervals, 2 s of speech", "textgrid", tg),
            ("the same TextGrid read with no limit (before)", "textgrid-unbounded", tg),
            ("transcript, 50k words, 2 s of speech", "transcript", words),
        ]
        print(f"limit {args.max_seconds:g} s; each case in a fresh process; peak = max RSS of that process")
        table = Rows(["case", "file size", "outcome", "seconds", "peak MB"])
        print(table.header())
        for name, kind, path in cases:
            r = run_case(kind, path, args.max_seconds)
            table.add(name, f"{path.stat().st_size / 1024:.0f} KB", r["outcome"], f"{r['seconds']:.2f}",
                      f"{r['peak_mb']:.0f}")
            print(table.last(), flush=True)
    save_json(args.json, table)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
