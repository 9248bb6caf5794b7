"""Generator speed on this machine: real-time factor over 60 s of speech per method and step count, the
GestureLSM-vs-DDIM ratio, and the per-step time of one CFG pair of a 128-frame window per preset.

    .venv/bin/python benchmarks/generator_speed.py [--checkpoints assets] [--threads 2] [--repeats 3]

All rows come from one run so that ratios hold on a noisy machine; times are medians of `--repeats`.
Speech: the real BEAT2 take 2_scott_0_2_2 (62 s, from ../shared) cropped to 60 s, else synthetic speech.
"""
from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
import torch

REPO = Path(__file__).resolve().parents[1]


def speech_60s() -> tuple[np.ndarray, str]:
    wav = REPO.parent / "shared" / "data" / "beat2" / "wave16k" / "2_scott_0_2_2.wav"
    if wav.exists():
        from gesturelsm.audio import load_audio

        return load_audio(wav)[: 60 * 16000], "BEAT2 2_scott_0_2_2 (first 60 s)"
    rng = np.random.default_rng(0)
    t = np.arange(60 * 16000) / 16000
    env = np.clip(np.sin(2 * np.pi * 3.1 * t), 0, None) ** 2
    return (0.3 * env * np.sin(2 * np.pi * 180 * t) * (0.8 + 0.2 * rng.random(len(t)))).astype(np.float32), "synthetic"


def median_time(fn, repeats: int) -> float:
    fn()  # warm-up
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return statistics.median(ts)


def per_step_ms(preset: str, repeats: int) -> tuple[float, float]:
    """One CFG pair (batch 2) of one 128-frame window through the denoiser, K/V cached as in sampling."""
    from gesturelsm.generator.config import PRESETS
    from gesturelsm.generator.model import GestureGenerator

    c = PRESETS[preset]
    m = GestureGenerator(c).eval()
    cond = torch.randn(1, c.window_latents, c.cond_dim)
    seed = torch.randn(1, c.num_regions, c.seed_latents, c.latent_dim)
    x = torch.randn(2, c.num_regions, c.window_latents, c.latent_dim)
    t = torch.full((2,), 0.5)
    drop = torch.tensor([False, True])
    with torch.inference_mode():
        f = m.bind(cond, seed)
        ms = median_time(lambda: f(x, t, t, drop), max(repeats, 20)) * 1000
    params = sum(p.numel() for p in m.denoiser.parameters()) / 1e6
    return ms, params


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--checkpoints", default=None)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    from gesturelsm.pipeline import GesturePipeline

    pipe = GesturePipeline.from_pretrained(args.checkpoints)
    y, src = speech_60s()
    speech = pipe.prepare_speech(y, 16000)
    print(f"speech: {src}, {speech.duration:.1f} s; torch threads {args.threads}; features "
          f"{speech.timings['features']:.2f} s (once per clip, included below)\n")
    rows = []
    plan = [("gesturelsm", s, 2.0) for s in (1, 2, 4, 8)] + [("rectified_flow", 8, 2.0), ("ddim", 20, 2.0)]
    for method, steps, cfg in plan:
        if method not in pipe.methods:
            continue
        secs = median_time(lambda: pipe.generate(speech, steps=steps, cfg=cfg, method=method), args.repeats)
        total = secs + speech.timings["features"]
        rows.append((method, steps, cfg, total, speech.duration / total))
    print("| method | steps | CFG | seconds for 60 s of speech | real-time factor |")
    print("|---|---|---|---|---|")
    for method, steps, cfg, secs, rtf in rows:
        print(f"| {method} | {steps} | {cfg} | {secs:.2f} | {rtf:.1f}x |")
    by = {(m, s): t for m, s, _, t, _ in rows}
    if ("gesturelsm", 8) in by and ("ddim", 20) in by:
        print(f"\nGestureLSM 8 steps vs DDIM 20 steps: {by[('ddim', 20)] / by[('gesturelsm', 8)]:.2f}x faster")
    print("\n| preset | denoiser params | ms per step (one CFG pair, 128-frame window) |")
    print("|---|---|---|")
    for preset in ("small", "paper"):
        ms, params = per_step_ms(preset, args.repeats)
        print(f"| {preset} | {params:.1f}M | {ms:.1f} |")


if __name__ == "__main__":
    main()
