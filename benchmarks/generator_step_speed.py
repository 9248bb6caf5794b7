"""The shipped generator's sampling step and whole clips, default modules vs kernels.accelerate, on this machine.

    .venv/bin/python benchmarks/generator_step_speed.py [--threads 1] [--rounds 30] [--seconds 10] [--steps 1 4 8]

Default: GestureGenerator.load(..., accelerated=False), plain torch modules. Accelerated: what every loader hands out
(GestureGenerator.load, kernels.accelerate). Both read the same checkpoint (assets/generator/gesturelsm.safetensors).
Per step: one guided call (conditional and null halves in one batch, as every sampler runs it) on a 128-frame
window. Per clip: generator.sampling.generate_latents over --seconds of speech, audio-only (as live mode runs),
at each of --steps, with the offline guidance 2.0. Calls alternate between the two models round by round, so load
from other processes on a shared machine hits both alike; the table gives medians of wall time and of this
process's CPU time (less sensitive to other processes taking the cores), their ratios, and the largest relative
difference of the outputs (max |fast - default| / max |default|, same seed).
Speech: the real BEAT2 take 2_scott_0_2_2 (from ../shared) when present, else a synthetic tone-and-noise signal.
"""
from __future__ import annotations

from _harness import BEAT2, set_threads

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
import torch

REPO = Path(__file__).resolve().parents[1]
WAV = BEAT2 / "wave16k" / "2_scott_0_2_2.wav"
CKPT = REPO / "assets" / "generator" / "gesturelsm.safetensors"


def speech(seconds: float) -> tuple[np.ndarray, str]:
    n = int(seconds * 16000)
    if WAV.exists():
        from gesturelsm.audio import load_audio

        y = load_audio(WAV)
        return np.resize(y, n).astype(np.float32), "BEAT2 2_scott_0_2_2"
    rng = np.random.default_rng(0)
    tt = np.arange(n) / 16000
    return (0.3 * np.sin(2 * np.pi * 180 * tt) * (np.sin(2 * np.pi * 3 * tt) > 0)
            + 0.02 * rng.standard_normal(n)).astype(np.float32), "synthetic"


def rel(a: torch.Tensor, b: torch.Tensor) -> float:
    return float((a - b).abs().max() / b.abs().max().clamp_min(1e-12))


def timed(fn) -> tuple[float, float, torch.Tensor]:
    w, c = time.perf_counter(), time.process_time()
    out = fn()
    return time.perf_counter() - w, time.process_time() - c, out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--rounds", type=int, default=30, help="interleaved rounds for the per-step rows")
    ap.add_argument("--clip-rounds", type=int, default=3, help="interleaved rounds for the per-clip rows")
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--steps", type=int, nargs="+", default=[1, 4, 8])
    args = ap.parse_args()
    set_threads(args.threads)
    from gesturelsm.evaluation.timing import hardware_name
    from gesturelsm.features.audio import audio_channels
    from gesturelsm.flows.base import guided
    from gesturelsm.generator.data import samples_for
    from gesturelsm.generator.model import GestureGenerator
    from gesturelsm.generator.sampling import generate_latents
    from gesturelsm.kernels import choices

    models = {"default": GestureGenerator.load(CKPT, accelerated=False), "accelerated": GestureGenerator.load(CKPT)}
    c = models["default"].config
    y, source = speech(args.seconds)
    ch = torch.from_numpy(audio_channels(y))
    T = int(args.seconds * 30)
    words, has_word = torch.zeros(T, c.text_in), torch.zeros(T, dtype=torch.bool)
    win = 4 * c.window_latents
    g = torch.Generator().manual_seed(0)
    x = torch.randn(1, c.num_regions, c.window_latents, c.latent_dim, generator=g)
    t, d = torch.full((1,), 0.25), torch.full((1,), 0.25)
    rows: list[tuple[str, dict[str, list[float]], dict[str, list[float]], float]] = []
    with torch.no_grad():
        fns = {}
        for k, m in models.items():
            n_a = samples_for(win)
            cond = m.speech(ch[None, :, :n_a], words[None, :win], has_word[None, :win], torch.tensor([False]))
            f = m.bind(cond, m.neutral_seed[None])
            fns[k] = (lambda f=f: guided(f, x, t, d, 6.0))
        cases = [("per step (guided, 128 frames)", fns, args.rounds)]
        for steps in args.steps:
            cases.append((f"per clip ({args.seconds:g} s, {steps} steps)",
                          {k: (lambda m=m, s=steps: generate_latents(m, ch, words, has_word, False, T, s, 2.0, seed=0))
                           for k, m in models.items()}, args.clip_rounds))
        for name, calls, rounds in cases:
            outs = {k: fn() for k, fn in calls.items()}                       # warm-up (traces, caches)
            wall: dict[str, list[float]] = {k: [] for k in calls}
            cpu: dict[str, list[float]] = {k: [] for k in calls}
            for _ in range(rounds):
                for k, fn in calls.items():
                    w, cp, outs[k] = timed(fn)
                    wall[k].append(w)
                    cpu[k].append(cp)
            rows.append((name, wall, cpu, rel(outs["accelerated"], outs["default"])))
            print(f"done: {name}", flush=True)
    print(f"\n{hardware_name('cpu')}, torch {torch.__version__} ({torch.backends.cpu.get_cpu_capability()}), "
          f"{args.threads} thread(s), fast paths taken: {sum(c.taken for c in choices())} of {len(choices())} choices "
          f"(benchmarks/kernels_speed.py lists them); speech: {source}\n")
    print("| case | default wall ms | accelerated wall ms | speed-up (wall) | default CPU ms | accelerated CPU ms "
          "| speed-up (CPU) | max rel. diff |")
    print("|---|---|---|---|---|---|---|---|")
    for name, wall, cpu, err in rows:
        med = {k: 1e3 * statistics.median(v) for k, v in wall.items()}
        mc = {k: 1e3 * statistics.median(v) for k, v in cpu.items()}
        print(f"| {name} | {med['default']:.1f} | {med['accelerated']:.1f} "
              f"| {med['default'] / med['accelerated']:.2f}x | {mc['default']:.1f} | {mc['accelerated']:.1f} "
              f"| {mc['default'] / mc['accelerated']:.2f}x | {err:.1e} |")


if __name__ == "__main__":
    main()
