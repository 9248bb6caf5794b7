"""The fast-kernel choices measured on this CPU, and what they give end to end.

    .venv/bin/python benchmarks/kernels_speed.py [--threads 1] [--seconds 67] [--steps 8] [--rounds 3] [--products]

1. Choices: the shipped generator and tokenizers (assets/) sample and decode --seconds of speech once with every
   choice measured from scratch (GESTURELSM_KERNELS=measure, a temporary cache file): each choice (a path for one
   shape), its ratio (default time / fast path's time; taken at >= kernels.choice.MARGIN), a summary per path, and
   what measuring cost on this first use.
2. End to end, three ways in turn each round (so load from other processes hits all alike), each with its own
   models: "default ops" (GESTURELSM_ONEDNN=0: exactly the plain modules' computation), "blocks only" (the models'
   faster blocks, no kernel path: GESTURELSM_KERNELS=none) and "kernels" (the choices of part 1). Sampling is
   generator.sampling.generate_latents (audio-only, CFG 2, --steps), decoding is decode_latents with the four
   tokenizers. Medians of wall time and of this process's CPU time over --rounds, the kernels' speed-up over the
   default ops (>= 1: not slower), and the largest relative difference of the outputs.
3. --products: GFLOP/s of F.linear (MKL) against oneDNN's product, and of conv1d against channels-last, for the
   authors' paper-size model's shapes, with the largest error against a float64 result.
Speech: the real BEAT2 take 2_scott_0_2_2 repeated to --seconds (from ../shared) when present, else synthetic.
"""
from __future__ import annotations

from _harness import set_threads

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import torch

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))

from generator_step_speed import CKPT, rel, speech  # noqa: E402  (this folder is on sys.path)
from kernels_products import env, products_table  # noqa: E402

from gesturelsm import kernels  # noqa: E402
from gesturelsm.kernels.cache import cpu_identity  # noqa: E402

WAYS = {"default ops": {"GESTURELSM_ONEDNN": "0"}, "blocks only": {"GESTURELSM_KERNELS": "none"}, "kernels": {}}


def clip_jobs(seconds: float, steps: int) -> dict[str, dict[str, object]]:
    """{way: {"sample": fn, "decode": fn}}, each way with its own generator and tokenizers."""
    from gesturelsm.backends.ours import load_tokenizers
    from gesturelsm.features.audio import audio_channels
    from gesturelsm.generator.model import GestureGenerator
    from gesturelsm.generator.sampling import decode_latents, generate_latents

    y, _ = speech(seconds)
    ch = torch.from_numpy(audio_channels(y))
    frames = int(seconds * 30)
    jobs: dict[str, dict[str, object]] = {}
    latents: list[torch.Tensor] = []              # every way decodes the same latents: the first sampled
    for way in WAYS:
        gen = GestureGenerator.load(CKPT)
        toks = load_tokenizers(REPO / "assets" / "tokenizer")
        words, has_word = torch.zeros(frames, gen.config.text_in), torch.zeros(frames, dtype=torch.bool)

        def sample(gen=gen, words=words, has_word=has_word):
            z = generate_latents(gen, ch, words, has_word, False, frames, steps, 2.0, seed=0)
            latents[:] = latents or [z]
            return z

        def decode(toks=toks):
            return torch.cat(list(decode_latents(toks, latents[0], frames).values()), -1)

        jobs[way] = {"sample": sample, "decode": decode}
    return jobs


def first_use(jobs) -> float:
    """Run the kernels' sampling and decoding once, measuring every choice; -> wall seconds of that first use."""
    start = time.perf_counter()
    with env({"GESTURELSM_KERNELS": "measure"}):
        jobs["kernels"]["sample"]()
        jobs["kernels"]["decode"]()
    return time.perf_counter() - start


def print_choices(first_s: float) -> None:
    made = kernels.choices()
    print(f"first use (sampling + decoding, measuring included): {first_s:.2f} s; measuring: "
          f"{kernels.probe_seconds():.2f} s for {len(made)} choices\n")
    print("| path | choices | taken | ratio min / median / max | fast path |")
    print("|---|---|---|---|---|")
    for path, what in kernels.PATHS.items():
        ratios = sorted(c.ratio for c in made if c.path == path and c.source != "failed")
        taken = sum(c.taken for c in made if c.path == path)
        spread = f"{ratios[0]:.2f} / {statistics.median(ratios):.2f} / {ratios[-1]:.2f}" if ratios else "-"
        print(f"| {path} | {len(ratios)} | {taken} | {spread} | {what} |")
    print("\n| choice | taken | ratio | measuring ms |\n|---|---|---|---|")
    for c in made:
        print(f"| {c.key} | {'yes' if c.taken else 'no'} | {c.ratio:.2f} | {1e3 * c.cost:.0f} |")


def end_to_end(jobs, rounds: int) -> None:
    rows = []
    for case in ("sample", "decode"):
        wall: dict[str, list[float]] = {w: [] for w in WAYS}
        cpu: dict[str, list[float]] = {w: [] for w in WAYS}
        outs = {}
        for way, values in WAYS.items():                               # warm-up (traces, first touches)
            with env(values):
                outs[way] = jobs[way][case]()
        for _ in range(rounds):
            for way, values in WAYS.items():
                with env(values):
                    w0, c0 = time.perf_counter(), time.process_time()
                    outs[way] = jobs[way][case]()
                    wall[way].append(time.perf_counter() - w0)
                    cpu[way].append(time.process_time() - c0)
        rows.append((case, wall, cpu, rel(outs["kernels"], outs["default ops"])))
    print(f"\n| case | {' | '.join(f'{w} wall / CPU s' for w in WAYS)} | kernels vs default ops (wall) | "
          "(CPU) | max rel. diff |")
    print("|---|---|---|---|---|---|---|")
    for case, wall, cpu, err in rows:
        mw = {w: statistics.median(v) for w, v in wall.items()}
        mc = {w: statistics.median(v) for w, v in cpu.items()}
        cells = " | ".join(f"{mw[w]:.2f} / {mc[w]:.2f}" for w in WAYS)
        print(f"| {'sampling' if case == 'sample' else 'decoding'} | {cells} | "
              f"{mw['default ops'] / mw['kernels']:.2f}x | {mc['default ops'] / mc['kernels']:.2f}x | {err:.1e} |")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--seconds", type=float, default=67.0)
    ap.add_argument("--steps", type=int, default=8)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--products", action="store_true", help="also the paper-size products table (part 3)")
    args = ap.parse_args()
    set_threads(args.threads)
    name, flags = cpu_identity()
    isa = [f for f in ("avx2", "avx512f", "avx512_bf16", "amx_tile") if f in flags.split()]
    with tempfile.TemporaryDirectory() as tmp, env({"GESTURELSM_KERNELS_CACHE": str(Path(tmp) / "kernels.json")}):
        kernels.forget()
        print(f"{name} ({', '.join(isa) or 'no AVX2'}), torch {torch.__version__}, {args.threads} thread(s); "
              f"load average {os.getloadavg()[0]:.1f}; speech {args.seconds:g} s, {args.steps} steps\n")
        jobs = clip_jobs(args.seconds, args.steps)
        print_choices(first_use(jobs))
        end_to_end(jobs, args.rounds)
        print(f"\nload average at the end {os.getloadavg()[0]:.1f}")
    if args.products:
        products_table(args.threads)


if __name__ == "__main__":
    main()
