"""Work every method pays once per request, for 60 s of real speech (the part of the time that does not shrink
with fewer steps, and so caps the GestureLSM-vs-DDIM speed ratio at less than 20 / 8).

    .venv/bin/python benchmarks/fixed_costs.py [--seconds 60] [--repeats 15] [--device cuda]

Stages, each timed alone (median of interleaved repeats, 2 threads; on a GPU synchronised before and after each
call, gesturelsm/evaluation/timing.py): audio channels (envelope + onsets, always on the CPU), the
speech encoder over all windows (batched as generation batches it), re-quantising and decoding the four region
tokenizers, 6D -> axis-angle. Speech: BEAT2 2_scott_0_2_2 from ../shared.
"""
from __future__ import annotations

from _harness import BEAT2, set_threads

import argparse
import statistics

import torch

WAV = BEAT2 / "wave16k" / "2_scott_0_2_2.wav"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--device", default="cpu", help="cpu, cuda or cuda:N")
    args = ap.parse_args()
    set_threads(2)
    from gesturelsm.audio import load_audio
    from gesturelsm.evaluation.timing import check_device, cpu_model, hardware_name, timed
    from gesturelsm.features.audio import audio_channels
    from gesturelsm.generator.data import samples_for
    from gesturelsm.generator.sampling import decode_latents, generate_latents, window_layout
    from gesturelsm.motion.rotations import rot6d_to_axis_angle
    from gesturelsm.pipeline import GesturePipeline

    try:
        dev = check_device(args.device)
    except ValueError as exc:
        raise SystemExit(str(exc)) from None
    if not WAV.exists():
        raise SystemExit(f"needs the real BEAT2 sample at {WAV}")
    pipe = GesturePipeline.from_pretrained(methods=["gesturelsm"], device=args.device)
    y = load_audio(WAV)[: int(args.seconds * 16000)]
    sp = pipe.prepare_speech(y, 16000, transcribe=False)            # audio-only, as measured before
    gen = pipe.generators["gesturelsm"]
    c = gen.config
    lat = generate_latents(gen, sp.channels, sp.word_features, sp.has_word, False, sp.num_frames, 8, 2.0, 0).to(dev)
    starts = window_layout(lat.shape[1], c.window_latents, c.seed_latents)[:16]   # one batch of windows
    n_a = samples_for(4 * c.window_latents)
    ch = torch.nn.functional.pad(sp.channels, (0, samples_for(4 * starts[-1]) + n_a))
    a = torch.stack([ch[:, samples_for(4 * s):samples_for(4 * s) + n_a] for s in starts]).to(dev)
    w = torch.zeros(len(starts), 4 * c.window_latents, sp.word_features.shape[1], device=dev)
    hw = torch.zeros(len(starts), 4 * c.window_latents, dtype=torch.bool, device=dev)
    parts = decode_latents(pipe.tokenizers, lat, sp.num_frames)
    from gesturelsm.motion.regions import join_regions

    d6 = join_regions(parts)[:, :330].reshape(-1, 55, 6)
    stages = {
        "audio channels": lambda: audio_channels(sp.audio),
        f"speech encoder ({len(starts)} windows)": lambda: gen.speech(a, w, hw, torch.zeros(len(a), dtype=torch.bool,
                                                                                          device=dev)),
        "re-quantise + decode 4 regions": lambda: decode_latents(pipe.tokenizers, lat, sp.num_frames),
        "6D -> axis-angle": lambda: rot6d_to_axis_angle(d6),
    }
    times: dict[str, list[float]] = {k: [] for k in stages}
    with torch.no_grad():
        for _ in range(args.repeats):
            for k, f in stages.items():
                times[k].append(timed(f, dev)[1])
    on = {k: f"cpu: {cpu_model()}" if k == "audio channels" else hardware_name(dev) for k in stages}
    print(f"{len(y) / 16000:.1f} s of speech, {lat.shape[1]} latents; median of {args.repeats} interleaved repeats\n")
    print("| stage | ms | measured on |")
    print("|---|---|---|")
    for k, v in times.items():
        print(f"| {k} | {statistics.median(v) * 1000:.1f} | {on[k]} |")


if __name__ == "__main__":
    main()
