"""The fast kernels on a machine's first run and in one-shot commands: whole `gesturelsm generate` processes.

    .venv/bin/python benchmarks/kernels_first_run.py [--rounds 3] [--short 10] [--long 62] [--threads 1]
                                                     [--only first|one-shot]

Wall clock of the whole process (start-up, model loading, generation, writing), medians over --rounds, the two
sides of each comparison run in turn (A B A B ...) so that load from other processes hits both alike:

1. First run against a warm one, on --short seconds of speech: "first run" has an empty kernel cache
   (GESTURELSM_KERNELS_CACHE pointing at a fresh file each time: every choice has to be measured, within the
   per-process budget of kernels/choice.py), "warm" a cache filled beforehand by an unbounded run on the same
   speech (GESTURELSM_KERNELS_BUDGET=1e9), as on a machine that has run before. The bar: first <= 1.2 x
   warm. The first run's one line on stderr is printed.
2. One-shot on --long seconds of speech: the fast paths with a filled cache against GESTURELSM_ONEDNN=0 (every
   fast path off). The bar: the fast paths' speed (ONEDNN=0 time / fast time) >= 0.97.

Speech: the held-out BEAT2 take 2_scott_0_2_2 (../shared, or $GESTURELSM_SHARED), cut to --short and --long
seconds, audio only (--no-transcribe: no speech recognition in the timings), the default method and settings,
--threads math threads (OMP_NUM_THREADS / MKL_NUM_THREADS; the issue measured one).
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _harness import REPO as ROOT
from _harness import take_wav

TAKE = take_wav("2_scott_0_2_2")


def cut(seconds: float, folder: Path) -> Path:
    import soundfile as sf

    audio, sr = sf.read(TAKE)
    out = folder / f"speech_{seconds:g}s.wav"
    sf.write(out, audio[: int(seconds * sr)], sr)
    return out


def run(wav: Path, out: Path, env: dict[str, str]) -> tuple[float, str]:
    """Seconds of one whole `gesturelsm generate` process, and its stderr."""
    cmd = [sys.executable, "-m", "gesturelsm", "generate", str(wav), "--no-transcribe", "--out", str(out)]
    t0 = time.perf_counter()
    p = subprocess.run(cmd, env=env, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stderr[-2000:]}")
    return wall, p.stderr


def base_env(threads: int) -> dict[str, str]:
    env = dict(os.environ)
    env.update(OMP_NUM_THREADS=str(threads), MKL_NUM_THREADS=str(threads), PYTHONPATH=str(ROOT))
    for var in ("GESTURELSM_KERNELS", "GESTURELSM_ONEDNN", "GESTURELSM_KERNELS_BUDGET"):
        env.pop(var, None)
    return env


def pairs(rounds: int, a, b) -> tuple[list[float], list[float]]:
    ta, tb = [], []
    for r in range(rounds):
        for side in ((a, ta), (b, tb)) if r % 2 == 0 else ((b, tb), (a, ta)):
            side[1].append(side[0](r))
            print(f"  round {r + 1}: {side[1][-1]:.1f} s", flush=True)
    return ta, tb


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--short", type=float, default=10.0)
    ap.add_argument("--long", type=float, default=62.0)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--only", choices=("first", "one-shot"), help="run one of the two comparisons")
    args = ap.parse_args()
    if not TAKE.exists():
        print(f"{TAKE} is absent: the held-out speech lives in ../shared", file=sys.stderr)
        return 2
    rows, said = [], ""
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        env = base_env(args.threads)
        short, long = cut(args.short, folder), cut(args.long, folder)
        warm_cache = folder / "warm.json"
        fill = dict(env, GESTURELSM_KERNELS_CACHE=str(warm_cache), GESTURELSM_KERNELS_BUDGET="1e9")
        print("filling the warm cache (unbounded measuring) ...", flush=True)
        for wav in (short, long):
            run(wav, folder / "fill.npz", fill)

        def first(r: int) -> float:
            nonlocal said
            wall, err = run(short, folder / "a.npz", dict(env, GESTURELSM_KERNELS_CACHE=str(folder / f"fresh{r}.json")))
            said = said or next((x for x in err.splitlines() if "timing the fast CPU kernels" in x), "")
            return wall

        def warm(r: int) -> float:
            return run(short, folder / "b.npz", dict(env, GESTURELSM_KERNELS_CACHE=str(warm_cache)))[0]

        if args.only != "one-shot":
            print(f"1. first run vs warm, {args.short:g} s of speech", flush=True)
            a, b = pairs(args.rounds, first, warm)
            rows.append((f"{args.short:g} s of speech: first run (empty cache) / warm cache", a, b, "<= 1.20"))

        def fast(r: int) -> float:
            return run(long, folder / "c.npz", dict(env, GESTURELSM_KERNELS_CACHE=str(warm_cache)))[0]

        def plain(r: int) -> float:
            return run(long, folder / "d.npz", dict(env, GESTURELSM_KERNELS_CACHE=str(warm_cache),
                                                     GESTURELSM_ONEDNN="0"))[0]

        if args.only != "first":
            print(f"2. one-shot, {args.long:g} s of speech: fast paths vs GESTURELSM_ONEDNN=0", flush=True)
            a, b = pairs(args.rounds, fast, plain)
            rows.append((f"{args.long:g} s of speech, one-shot: fast paths / GESTURELSM_ONEDNN=0", a, b,
                         "<= 1.03"))
    print()
    print("| comparison | A median s | B median s | A / B | bar | runs A | runs B |")
    print("|---|---|---|---|---|---|---|")
    for name, a, b, bar in rows:
        ma, mb = statistics.median(a), statistics.median(b)
        print(f"| {name} | {ma:.1f} | {mb:.1f} | {ma / mb:.2f} | {bar} | {', '.join(f'{x:.1f}' for x in a)} | "
              f"{', '.join(f'{x:.1f}' for x in b)} |")
    print()
    print(f"{args.threads} math thread(s), {args.rounds} rounds, load average {os.getloadavg()[0]:.1f} at the end.")
    print(f"The first run said: {said or '(nothing)'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
