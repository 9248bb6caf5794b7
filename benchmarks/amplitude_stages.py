"""Where is gesture amplitude lost? Each stage measured on held-out speech.

    .venv/bin/python benchmarks/amplitude_stages.py [--checkpoints assets] [--seeds 2] [--stages all]

Held-out speech: the last 20 % of 2_scott_0_1_1 (the shipped models trained on its first 80 %) and the
audio-only takes 2_scott_0_2_2, 2_scott_0_3_3, audio-only and with their MFA transcripts. Statistics
(gesturelsm/metrics/amplitude.py, wrists relative to the pelvis, y up, metres) pooled over clips x seeds,
in brackets the ratio to the speaker's whole take (the held-out 20 % alone is a calmer stretch: 14.7 % raised); replay
guard = median distance of 1 s upper-body windows to the nearest training window, over the same for the speaker's
held-out motion. Generated motion is post-processed as the app does by default (--smoothing, default light: a 5-frame
Savitzky-Golay filter, see motion/postprocess.py); the jerk before it is shown in brackets ("raw").

Stages (--stages, any of):
  speaker     the speaker: held-out 20 % and training 80 %
  tokenizer   the real held-out motion through encode -> re-quantise -> decode of the shipped tokenizers
  methods     every method at --steps (DDIM also at 20), CFG --cfg, audio-only and transcript
  cfg         GestureLSM at 8 steps over CFG scales --cfg-scan
  seed        GestureLSM at 8 steps: neutral first-window seed vs seeds from the speaker's rest moments
  decay       GestureLSM at 8 steps, audio-only: raised share in the first window (frames 0-127, shaped by the
              first-window seed) and after it (each window seeded by the previous one's latents), for the neutral
              seed and for seeds from the speaker's most raised spans: does a raised start persist or decay?
  interval    GestureLSM at 8 steps: CFG only for t in an interval (t = 0 noise, t = 1 data)
  respread    diagnostic, not a fix: GestureLSM's generated latents with their deviation from the training mean
              stretched so each region's spread equals the training latents' (then re-quantised and decoded):
              does the lost amplitude come back when only the latent spread is restored?
  latents     spread of the generated latents (before re-quantisation) against the real motion's, per region:
              std over frames and seeds in the generator's scaled space (the training latents have std 1)
"""
from __future__ import annotations

from _harness import BEAT2, set_threads

import argparse
from pathlib import Path

import numpy as np
import torch

from gesturelsm.motion.postprocess import DEFAULT_SMOOTHING, SMOOTHING_WINDOWS

REPO = Path(__file__).resolve().parents[1]
STAGES = ("speaker", "tokenizer", "methods", "cfg", "seed", "decay", "interval", "latents", "respread")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--checkpoints", default=None)
    ap.add_argument("--data", default=str(BEAT2))
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--steps", type=int, nargs="+", default=[4, 8])
    ap.add_argument("--cfg", type=float, default=2.0)
    ap.add_argument("--cfg-scan", type=float, nargs="+", default=[1.0, 2.0, 3.0, 4.0])
    ap.add_argument("--stages", nargs="+", default=list(STAGES), choices=STAGES)
    ap.add_argument("--methods", nargs="+", default=None, help="methods of the latents stage (default: all)")
    ap.add_argument("--text", choices=["both", "audio", "transcript"], default="both")
    ap.add_argument("--smoothing", default=DEFAULT_SMOOTHING, choices=list(SMOOTHING_WINDOWS),
                    help="post-processing of generated motion, as the app applies it (jerk before it in brackets)")
    args = ap.parse_args()
    from gesturelsm.evaluation.amplitude import AmplitudeData, format_rows, rest_seeds
    from gesturelsm.generator.data import encode_regions
    from gesturelsm.generator.sampling import decode_latents
    from gesturelsm.motion.regions import join_regions
    from gesturelsm.motion.sequence import MotionSequence
    from gesturelsm.pipeline import GesturePipeline

    if not Path(args.data).exists():
        raise SystemExit(f"needs the real BEAT2 sample at {args.data}")
    data = AmplitudeData.load(args.data)
    data.smoothing = args.smoothing
    pipe = GesturePipeline.from_pretrained(args.checkpoints)
    seeds = list(range(args.seeds))
    modes = {"both": [False, True], "audio": [False], "transcript": [True]}[args.text]
    speaker = data.speaker_rows()
    rows = list(speaker) if "speaker" in args.stages else []

    def show(title: str) -> None:
        print(f"\n### {title}\n\n{format_rows(rows, speaker[0].stats)}\n", flush=True)
        rows.clear()

    if rows:
        show("the speaker")
    if "tokenizer" in args.stages:
        for c in (c for c in data.clips if c.motion is not None):
            feats = c.motion.to_features()
            lat = encode_regions(pipe.tokenizers, feats)
            rec = MotionSequence.from_features(join_regions(decode_latents(pipe.tokenizers, lat, len(feats))))
            rows.append(data.row(f"tokenizer round trip of {c.name} held-out", [data.joints(rec)]))
        rows.append(speaker[1])
        show("tokenizer round trip (encode, re-quantise, decode)")
    plan = []
    if "methods" in args.stages:
        plan += [(m, s) for m in pipe.methods for s in args.steps] + ([("ddim", 20)] if "ddim" in pipe.methods else [])
    for m, s in plan:
        for text in modes:
            rows.append(data.generated(pipe, m, s, args.cfg, text, seeds))
    if plan:
        show(f"methods and steps, CFG {args.cfg:g}")
    if "cfg" in args.stages:
        for c in args.cfg_scan:
            for text in modes:
                rows.append(data.generated(pipe, "gesturelsm", 8, c, text, seeds))
        show("GestureLSM 8 steps over CFG scales")
    if "seed" in args.stages:
        bank = rest_seeds(pipe, "gesturelsm", data.train)
        for text in modes:
            mode = "transcript" if text else "audio-only"
            rows.append(data.generated(pipe, "gesturelsm", 8, args.cfg, text, seeds, f"neutral seed, {mode}"))
            rows.append(data.generated(pipe, "gesturelsm", 8, args.cfg, text, seeds, f"rest seed, {mode}",
                                       seed_bank=bank))
        show(f"GestureLSM 8 steps CFG {args.cfg:g}: first-window seed")
    if "decay" in args.stages:
        decay(pipe, data, seeds, args.cfg)
    if "interval" in args.stages:
        for iv in [(0.0, 1.0), (0.0, 0.5), (0.25, 0.75), (0.5, 1.0)]:
            for text in modes:
                mode = "transcript" if text else "audio-only"
                rows.append(data.generated(pipe, "gesturelsm", 8, args.cfg, text, seeds,
                                           f"CFG for t in [{iv[0]:g}, {iv[1]:g}), {mode}", guidance_interval=iv))
        show(f"GestureLSM 8 steps CFG {args.cfg:g}: guidance interval")
    if "respread" in args.stages:
        for text in modes:
            rows.append(respread(pipe, data, seeds, 8, args.cfg, text))
        show(f"GestureLSM 8 steps CFG {args.cfg:g}, latent spread restored (diagnostic)")
    if "latents" in args.stages:
        latent_spread(pipe, data, seeds, args.steps, args.cfg, args.methods or pipe.methods)


def raised_seeds(pipe, data, method: str = "gesturelsm", count: int = 8) -> list[torch.Tensor]:
    """`count` first-window seeds (R, s, D) from the training spans where the speaker's wrists are highest."""
    from gesturelsm.generator.data import encode_regions
    from gesturelsm.metrics.amplitude import wrist_heights

    model = pipe.generators[method]
    s, spans = model.config.seed_latents, []
    for m in data.train:
        lat = encode_regions(pipe.tokenizers, m.to_features()) / model.latent_std.cpu()[:, None, None]  # (R, L, D)
        high = wrist_heights(data.joints(m)).max(1)                                   # (T,) higher wrist, m
        spans += [(float(high[4 * a:4 * (a + s)].mean()), lat[:, a:a + s]) for a in range(0, lat.shape[1] - s + 1, s)]
    spans.sort(key=lambda p: p[0])
    return [lat for _, lat in spans[-count:]]


def decay(pipe, data, seeds: list[int], cfg: float, window: int = 128) -> None:
    from gesturelsm.evaluation.amplitude import sampling_options
    from gesturelsm.metrics.amplitude import RAISED_M, wrist_heights

    print(f"\n### GestureLSM 8 steps CFG {cfg:g}, audio-only: raised share by position\n")
    print("| first-window seed | first window (0-4.3 s) | after it | whole clips |\n|---|---|---|---|")
    model = pipe.generators["gesturelsm"]
    for name, bank in (("neutral pose", None), ("speaker's most raised spans", raised_seeds(pipe, data))):
        first, after = [], []
        for k in seeds:
            with sampling_options(model, seed_latents=None if bank is None else bank[k % len(bank)]):
                for c in data.clips:
                    res = pipe.generate(pipe.prepare_speech(c.audio, 16000), steps=8, cfg=cfg, seed=k,
                                        method="gesturelsm", output="raw")
                    up = (wrist_heights(data.joints(res.motion)) > RAISED_M).any(1)     # (T,) a wrist raised
                    first.append(up[:window]), after.append(up[window:])
        f, a = np.concatenate(first), np.concatenate(after)
        both = np.concatenate([f, a])
        print(f"| {name} | {100 * f.mean():.1f} % | {100 * a.mean():.1f} % | {100 * both.mean():.1f} % |")


def latent_spread(pipe, data, seeds: list[int], steps: list[int], cfg: float, methods: list[str]) -> None:
    """Per-region std (over frames, dims) of latents: real training / held-out motion encoded, and generated."""
    from gesturelsm.generator.data import encode_regions
    from gesturelsm.generator.sampling import generate_latents

    regions = list(pipe.tokenizers)
    print("\n### latent spread (scaled by the training latent std; real training latents = 1)\n")
    print("| latents | " + " | ".join(regions) + " | distance of the mean from the training mean |")
    print("|---|" + "---|" * (len(regions) + 1))
    model = pipe.generators["gesturelsm"]
    std = model.latent_std.cpu()[:, None, None]
    mirrored = [x for m in data.train for x in (m, m.mirrored())]                # training used both
    train = torch.cat([encode_regions(pipe.tokenizers, m.to_features()) for m in mirrored], 1) / std
    mu = train.mean(1, keepdim=True)                                             # (R, 1, D)

    def line(name: str, lat: torch.Tensor) -> None:                              # lat (R, L, D) scaled
        sd = lat.std(dim=(1, 2))
        gap = (lat.mean(1, keepdim=True) - mu).norm(dim=-1).squeeze(1) / mu.shape[-1] ** 0.5
        print(f"| {name} | " + " | ".join(f"{v:.2f}" for v in sd) + " | "
              + " / ".join(f"{v:.2f}" for v in gap) + " |", flush=True)

    line("real, training 80 % and its mirror image", train)
    line("neutral first-window seed", model.neutral_seed.cpu())
    held = [c for c in data.clips if c.motion is not None]
    line("real, held-out 20 %",
         torch.cat([encode_regions(pipe.tokenizers, c.motion.to_features()) for c in held], 1) / std)
    for method in methods:
        for n in steps:
            for text in (False, True):
                lats = []
                for c in data.clips:
                    sp = pipe.prepare_speech(c.audio, 16000, words=c.words if text else None)
                    for k in seeds:
                        lats.append(generate_latents(pipe.generators[method], sp.channels, sp.word_features,
                                                     sp.has_word, text, sp.num_frames, n, cfg, k) / std)
                line(f"{method} {n} steps CFG {cfg:g} {'transcript' if text else 'audio-only'}", torch.cat(lats, 1))


def training_latents(pipe, data) -> torch.Tensor:
    """(R, L, D) scaled latents of the training motion and its mirror image (as the generator trained)."""
    from gesturelsm.generator.data import encode_regions

    std = pipe.generators["gesturelsm"].latent_std.cpu()[:, None, None]
    mirrored = [x for m in data.train for x in (m, m.mirrored())]
    return torch.cat([encode_regions(pipe.tokenizers, m.to_features()) for m in mirrored], 1) / std


def respread(pipe, data, seeds: list[int], steps: int, cfg: float, text: bool):
    from gesturelsm.generator.sampling import decode_latents, generate_latents
    from gesturelsm.motion.regions import join_regions
    from gesturelsm.motion.sequence import MotionSequence

    model = pipe.generators["gesturelsm"]
    std = model.latent_std.cpu()[:, None, None]
    train = training_latents(pipe, data)
    mu, sd = train.mean(1, keepdim=True), train.std(dim=(1, 2))[:, None, None]
    motions = []
    for c in data.clips:
        sp = pipe.prepare_speech(c.audio, 16000, words=c.words if text else None)
        for k in seeds:
            lat = generate_latents(model, sp.channels, sp.word_features, sp.has_word, text, sp.num_frames,
                                   steps, cfg, k)
            z = lat / std
            z = mu + (z - mu) * sd / z.std(dim=(1, 2), keepdim=True)                # each region at training spread
            feats = join_regions(decode_latents(pipe.tokenizers, z * std, sp.num_frames))
            motions.append(data.joints(MotionSequence.from_features(feats)))
    return data.row(f"spread restored, {'transcript' if text else 'audio-only'}", motions)


if __name__ == "__main__":
    set_threads(1)
    main()
