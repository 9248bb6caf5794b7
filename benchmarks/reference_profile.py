"""Where one window of the authors' paper-size model spends its time on this CPU (our reference implementation,
random weights: timing does not depend on them). Prints a markdown table: the speech encoder (and each of its six
strided conv blocks), the cross-attention keys/values (computed once per clip), and one denoiser step with the
classifier-free-guidance pair, for a 128-frame window.

    .venv/bin/python benchmarks/reference_profile.py [--threads 1] [--repeats 5]
"""
from __future__ import annotations

from _harness import set_threads

import argparse
import statistics

import torch

from gesturelsm.evaluation.timing import timed
from gesturelsm.kernels import channels_last_1d
from gesturelsm.reference.config import GeneratorConfig
from gesturelsm.reference.model import ReferenceGenerator
from gesturelsm.reference.samplers import _velocity, guided_kv


def median_seconds(fn, repeats: int) -> float:
    """Median wall time of `fn` over `repeats` calls after one warm-up call (evaluation.timing.timed on the CPU)."""
    fn()
    return statistics.median(timed(fn, "cpu")[1] for _ in range(repeats))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    set_threads(args.threads)
    torch.manual_seed(0)
    cfg = GeneratorConfig()
    g = ReferenceGenerator(cfg).eval()
    n = cfg.frames
    audio, words = torch.rand(1, 533 * n, 2), torch.randint(0, 100, (1, n))          # (B, S, 2), (B, frames)
    seed = torch.randn(1, cfg.seed_frames, cfg.regions * cfg.input_dim)
    x = torch.randn(1, cfg.regions * cfg.input_dim, cfg.seq_len)
    rows = []
    with torch.inference_mode():
        speech = g.speech(audio, words)
        rows.append(("speech encoder (per window)", median_seconds(lambda: g.speech(audio, words), args.repeats)))
        h = channels_last_1d(audio.transpose(1, 2))         # the eval path: folded BatchNorms, channels-last
        for i, (block, folded) in enumerate(zip(g.speech.wav, g.speech.folded_convs())):
            # blocks without a downsampling branch write into their input: each timed call gets a copy
            fresh = (lambda: h.clone()) if block.down is None else (lambda: h)
            rows.append((f"  conv block {i} on {(h.shape[1], h.shape[3])}",
                         median_seconds(lambda: block.fast(fresh(), folded), args.repeats)))
            h = block.fast(fresh(), folded)
        rows.append(("cross-attention keys/values, CFG pair (per clip)",
                     median_seconds(lambda: guided_kv(g.denoiser, speech, 2.0), args.repeats)))
        f = _velocity(g.denoiser, guided_kv(g.denoiser, speech, 2.0), seed, 2.0)
        t, d = torch.tensor([0.5]), torch.tensor([0.5])
        rows.append(("denoiser step, CFG pair (per step)", median_seconds(lambda: f(x, t, d), args.repeats)))
    print(f"paper-size reference model, {args.threads} thread(s), median of {args.repeats}\n")
    print("| part | seconds |\n|---|---|")
    for name, sec in rows:
        print(f"| {name} | {sec:.4f} |")


if __name__ == "__main__":
    main()
