"""Generator speed on this machine: a thin wrapper over `gesturelsm bench` (gesturelsm/evaluation/bench.py).

    .venv/bin/python benchmarks/generator_speed.py [--checkpoints assets] [--threads 2] [--repeats 3] [--device cuda]

Per step time, AITS, real-time factors for 10 s and 60 s of speech and peak memory for GestureLSM at 1/2/4/8/20
steps vs rectified flow and DDIM, shipped and paper-size, all from one run (interleaved rounds, medians).
Every timed call is synchronised before and after on a GPU (gesturelsm/evaluation/timing.py); the table names the
GPU (or "cpu: <model>") beside every figure.
Speech: the real BEAT2 take 2_scott_0_2_2 (from ../shared) when present, else synthetic speech. For the JSON,
the plot and the end-to-end timing use `gesturelsm bench --data ... --out DIR`.
"""
from __future__ import annotations

from _harness import BEAT2, set_threads

import argparse
from pathlib import Path


REPO = Path(__file__).resolve().parents[1]
WAV = BEAT2 / "wave16k" / "2_scott_0_2_2.wav"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--checkpoints", default=None)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--steps", type=int, nargs="+", default=[1, 2, 4, 8, 20])
    ap.add_argument("--presets", nargs="+", default=["shipped", "paper"])
    ap.add_argument("--device", default="cpu", help="cpu, cuda or cuda:N")
    args = ap.parse_args()
    set_threads(args.threads)
    from gesturelsm.evaluation.bench import run_bench
    from gesturelsm.evaluation.timing import check_device
    from gesturelsm.evaluation.tables import bench_markdown

    try:
        check_device(args.device)
    except ValueError as exc:
        raise SystemExit(str(exc)) from None
    speech = None
    if WAV.exists():
        from gesturelsm.audio import load_audio

        speech = load_audio(WAV)
    rep = run_bench(args.checkpoints, tuple(args.presets), steps=tuple(args.steps), repeats=args.repeats,
                    device=args.device, speech=speech, log=lambda m: print(m, flush=True))
    print(f"speech: {'BEAT2 2_scott_0_2_2' if speech is not None else 'synthetic'}\n")
    print(bench_markdown(rep))


if __name__ == "__main__":
    main()
