"""Speed of a sweep on this machine: `gesturelsm sweep`'s library path on a 10 s clip with the shipped models,
3 methods x 4 step counts x 3 CFG scales x 2 seeds (72 motions), timed as a whole and by part, and the page's
statistics step (all statistics of three 10 s motions, what runs after the player starts).

    .venv/bin/python benchmarks/sweep_speed.py [--seconds 10] [--steps 1 2 4 8] [--cfg 1 2 3] [--seeds 2]
                                               [--threads N] [--out DIR] [--metric wrist_speed] [--repeats 5]

Speech: the first `--seconds` of the BEAT2 take 2_scott_0_2_2 (../shared) when present, else gesturelsm/webapp/examples'
weekend.wav looped. Rows: wall time of the whole sweep (speech features once, then every motion generated and
measured), the sum of the pipeline's generation times, the statistics' share, and the median over `--repeats` of
the page's statistics for three methods' motions. One run; the machine may be shared with other jobs (the load
average before and after is printed). With `--out`, the sweep's table and plot are written there.
"""
from __future__ import annotations

from _harness import BEAT2, set_threads

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
SHARED = BEAT2 / "wave16k" / "2_scott_0_2_2.wav"
EXAMPLE = REPO / "gesturelsm" / "webapp" / "examples" / "weekend.wav"


def clip(seconds: float) -> tuple[np.ndarray, str]:
    from gesturelsm.audio import load_audio

    src = SHARED if SHARED.exists() else EXAMPLE
    y = load_audio(src)
    n = int(seconds * 16000)
    return np.resize(y, n) if len(y) < n else y[:n], src.name


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--methods", nargs="+", default=None)
    ap.add_argument("--steps", nargs="+", type=int, default=[1, 2, 4, 8])
    ap.add_argument("--cfg", nargs="+", type=float, default=[1.0, 2.0, 3.0])
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--metric", default="wrist_speed")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    import torch

    from gesturelsm.evaluation.motion_stats import SpeechContext, motion_statistics, speaker_reference
    from gesturelsm.evaluation.sweep import SweepGrid, SweepLimits, check_grid, run_sweep
    from gesturelsm.evaluation.sweep_report import markdown_text, write_sweep
    from gesturelsm.evaluation.timing import cpu_model
    from gesturelsm.pipeline import GesturePipeline

    if args.threads:
        set_threads(args.threads)
    audio, name = clip(args.seconds)
    pipe = GesturePipeline.from_pretrained()
    grid = SweepGrid(tuple(args.methods or pipe.methods), tuple(args.steps), tuple(args.cfg), args.seeds)
    check_grid(pipe, grid, args.seconds, SweepLimits())
    load0 = os.getloadavg()[0]
    t0, c0 = time.perf_counter(), time.process_time()
    speech = pipe.prepare_speech(audio, 16000, transcribe=False)
    result = run_sweep(pipe, speech, grid, keep_motions=True,
                       progress=lambda f, m: print(f"[{100 * f:3.0f} %] {m}", file=sys.stderr, flush=True))
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    gen = sum(r.seconds for r in result.runs)
    load1 = os.getloadavg()[0]

    ref = speaker_reference()
    shown = {}
    for r in result.runs:                                  # one motion per method, as the page shows them
        shown.setdefault(r.method, r.motion)
    times, cpus = [], []
    for _ in range(args.repeats):
        s0, p0 = time.perf_counter(), time.process_time()
        ctx = SpeechContext.of(speech.audio, ref.mean_speed if ref else None)
        for m in shown.values():
            motion_statistics(m, None, ctx)
        times.append(time.perf_counter() - s0)
        cpus.append(time.process_time() - p0)

    print(f"\n{cpu_model()}, torch threads {torch.get_num_threads()}, {os.cpu_count()} cores; "
          f"load average {load0:.1f} before, {load1:.1f} after (other jobs share this machine)")
    print(f"speech: {args.seconds:g} s of {name}; grid: {', '.join(grid.methods)} x steps {list(grid.steps)} x "
          f"CFG {list(grid.cfgs)} x {grid.seeds} seeds = {len(result.runs)} motions\n")
    print("| part | wall seconds | process CPU seconds (all threads) |\n|---|---|---|")
    print(f"| whole sweep (features once, generate + measure every motion) | {wall:.1f} | {cpu:.1f} |")
    print(f"| generation (sum of the pipeline's generation times) | {gen:.1f} | |")
    print(f"| speech features, statistics and the rest (whole - generation) | {wall - gen:.1f} | |")
    print(f"| page statistics, {len(shown)} motions of {args.seconds:g} s (median of {args.repeats}; "
          f"min {min(times):.3f}) | {statistics.median(times):.3f} | {statistics.median(cpus):.3f} |")
    print(f"\nunder 2 minutes: {'yes' if wall < 120 else 'no'} ({wall:.1f} s)")
    if args.out:
        files = write_sweep(result, Path(args.out), args.metric)
        print(markdown_text(result))
        print(f"wrote {', '.join(str(p) for p in files.values())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
