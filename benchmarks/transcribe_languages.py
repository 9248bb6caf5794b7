"""English transcription before and after the multilingual recogniser was added, in one run (markdown out).

    NUMBA_CACHE_DIR=.venv/numba-cache .venv/bin/python benchmarks/transcribe_languages.py \
        --before REV [--data DIR]

The package at the commit `--before` (taken from git into a temporary folder) and the working tree each transcribe the
real BEAT2 takes (wave16k/*.wav) with the default settings (language auto), alternating, in fresh processes; the
table gives the time per take (model loaded beforehand) and whether the words and their times are identical.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from _harness import BEAT2, REPO

CHILD = r"""
import json, sys, time
import soundfile as sf
from gesturelsm.asr import transcribe
from gesturelsm.asr.model import load_model
load_model()
out = {}
for path in sys.argv[1:]:
    y, _ = sf.read(path, dtype="float32")
    t = time.perf_counter(); tr = transcribe(y); dt = time.perf_counter() - t
    out[path] = {"s": dt, "lang": tr.language,
                 "words": [[w.text, round(w.start, 4), round(w.end, 4)] for w in tr.words]}
print(json.dumps(out))
"""


def run(tree: Path, wavs: list[str]) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree)}
    res = subprocess.run([sys.executable, "-c", CHILD, *wavs], env=env, capture_output=True, text=True, check=True,
                         cwd=tree)
    return json.loads(res.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", required=True, metavar="REV", help="the commit to compare against (one without the "
                    "multilingual recogniser)")
    ap.add_argument("--data", type=Path, default=BEAT2)
    ap.add_argument("--rounds", type=int, default=2)
    args = ap.parse_args()
    wavs = sorted(str(p) for p in (args.data / "wave16k").glob("*.wav"))
    with tempfile.TemporaryDirectory() as tmp:
        old = Path(tmp)
        archive = subprocess.run(["git", "-C", str(REPO), "archive", args.before, "gesturelsm"], capture_output=True,
                                 check=True).stdout
        subprocess.run(["tar", "-x", "-C", str(old)], input=archive, check=True)
        times: dict[str, dict[str, list[float]]] = {"before": {}, "after": {}}
        last = {}
        for _ in range(args.rounds):                          # alternating, so both see the same machine load
            for name, tree in (("before", old), ("after", REPO)):
                got = run(tree, wavs)
                last[name] = got
                for w, r in got.items():
                    times[name].setdefault(w, []).append(r["s"])
    print("| take | before (s) | after (s) | words | same words and times | language after |")
    print("|---|---|---|---|---|---|")
    for w in wavs:
        b, a = last["before"][w], last["after"][w]
        print(f"| {Path(w).stem} | {min(times['before'][w]):.2f} | {min(times['after'][w]):.2f} | {len(a['words'])} | "
              f"{'yes' if a['words'] == b['words'] else 'NO'} | {a['lang']} |")
    print(f"\n(best of {args.rounds} per take and version; `--before {args.before}`)")


if __name__ == "__main__":
    main()
