"""`gesturelsm live FILE`: read a speech file as if it came from a microphone, stream motion out, print latency.

    gesturelsm live speech.wav --chunk-ms 200 --out motion.npz            # as fast as possible
    gesturelsm live speech.wav --realtime                                 # chunks arrive at the pace of speech
    gesturelsm live speech.wav --grounding off                            # the decoder's legs, feet not planted
    gesturelsm live speech.wav --realtime --vmc 127.0.0.1:39539           # to VSeeFace / VNyan / Unity (VMC)
"""
from __future__ import annotations

import argparse

import numpy as np

from ..constants import SAMPLE_RATE
from ..errors import GestureError
from ..settings import CLI, Asked, settings_problems
from ..settings.arguments import input_file, output_file, positive, refuse, threads
from ..settings.values import from_text, whole_number

NAME = "live"
HELP = "stream a speech file through the live generator (as if from a microphone)"




def add_parser(sub) -> None:
    from ..live.config import LiveConfig

    p = sub.add_parser(NAME, help=HELP,
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("audio", help="speech file (any common format and rate)")
    p.add_argument("--chunk-ms", type=from_text, default=200.0, help="audio chunk size")
    p.add_argument("--realtime", action="store_true",
                   help="feed chunks at the pace of speech (else as fast as possible)")
    p.add_argument("--out", default=None, help="write the streamed motion as BEAT2 npz")
    p.add_argument("--steps", type=from_text, default=LiveConfig.steps, help="sampler steps per window")
    p.add_argument("--cfg", type=from_text, default=LiveConfig.cfg, help="classifier-free guidance scale")
    p.add_argument("--seed", type=from_text, default=LiveConfig.seed, help="generation seed")
    p.add_argument("--commit", type=from_text, default=LiveConfig.commit,
                   help="latents finalised per window (4 frames each)")
    p.add_argument("--lookahead", type=from_text, default=LiveConfig.lookahead,
                   help="latents of audio look-ahead (--commit 2 --lookahead 0: the fast setting, about 0.3 s behind "
                   "the voice, the motion following the loudness less: docs/LIVE.md)")
    p.add_argument("--held", type=from_text, default=LiveConfig.held,
                   help="final latents before the new ones held fixed while sampling (0: all in the window)")
    p.add_argument("--grounding", choices=("on", "off"), default="on",
                   help="feet on the ground, causally, chunk by chunk (off: the decoder's legs and root as they come)")
    p.add_argument("--threads", type=from_text, default=1,
                   help="torch threads (more than 1 on a busy 2-core machine made live generation 15x slower)")
    p.add_argument("--checkpoints", default=None, help="folder with tokenizer/ and generator/ (default: shipped)")
    p.add_argument("--vmc", help="send the stream as VMC protocol bundles to HOST:PORT (VSeeFace, VNyan, Warudo, "
                   "EVMC4U ...: docs/ENGINES.md), each committed chunk's frames on a steady 30 fps clock")
    p.add_argument("--livelink", help="send the face as Live Link Face packets to HOST:PORT (Unreal, port 11111)")
    p.add_argument("--perfect-sync", action="store_true", help="with --vmc: the 52 ARKit blendshapes too")
    p.set_defaults(func=run)


def check_arguments(args: argparse.Namespace) -> tuple:
    """(config, chunk ms, threads): every argument before any work, all problems at once (InputError)."""
    from ..export.engine_stream import parse_address
    from ..live.config import LiveConfig

    p: list[str] = []
    settings, found = settings_problems(Asked([LiveConfig.method], args.steps, cfg=args.cfg, seed=args.seed),
                                        [LiveConfig.method], names=CLI)
    p += found
    chunk_ms = positive(args.chunk_ms, "--chunk-ms", p, hi=10_000)
    commit = whole_number(args.commit, "--commit", 1, 1000, p)
    lookahead = whole_number(args.lookahead, "--lookahead", 0, 1000, p)
    held = whole_number(args.held, "--held", 0, 1000, p)
    n_threads = threads(args.threads, p)
    input_file(args.audio, "AUDIO", p)
    out = output_file(args.out, "--out", ".npz", p) if args.out else None
    for flag in ("--vmc", "--livelink"):
        value = getattr(args, flag[2:], None)
        if value:
            try:
                parse_address(value, flag)
            except GestureError as exc:
                p.append(str(exc))
    refuse(p)
    cfg = LiveConfig(commit=commit, lookahead=lookahead, held=held, steps=settings.steps_for(LiveConfig.method),
                     cfg=settings.cfg, seed=settings.seed, grounding=args.grounding == "on")
    return cfg, chunk_ms, n_threads, out


def run(args: argparse.Namespace) -> int:
    from ..audio import load_audio
    from ..backends import checkpoint_sources
    from ..export.engine_stream import EngineStream, parse_address
    from ..features.audio import audio_channels
    from ..live.from_file import run_file
    from ..pipeline import GesturePipeline

    cfg, chunk_ms, n_threads, out = check_arguments(args)
    audio = load_audio(args.audio)
    import torch

    torch.set_num_threads(n_threads)

    pipe = GesturePipeline.from_pretrained(checkpoints=checkpoint_sources(args.checkpoints), methods=[cfg.method],
                                           warm_up=False)   # audio only
    # JIT outside the timing
    audio_channels(np.random.default_rng(0).normal(scale=0.1, size=SAMPLE_RATE).astype(np.float32))
    engines = None
    if getattr(args, "vmc", None) or getattr(args, "livelink", None):
        engines = EngineStream(parse_address(args.vmc, "--vmc") if args.vmc else None,
                               parse_address(args.livelink, "--livelink") if args.livelink else None,
                               args.perfect_sync).start()
    try:
        res = run_file(pipe, audio, cfg, chunk_ms, args.realtime, engines)
    finally:
        report = engines.close() if engines is not None else None
    look = (cfg.commit + cfg.lookahead) * 4 / 30
    print(f"{res.audio_seconds:.1f} s of audio in {len(res.latencies)} chunks of {chunk_ms:.0f} ms "
          f"({'real-time pacing' if args.realtime else 'as fast as possible'}); look-ahead <= {look:.2f} s; "
          f"feet on the ground: {args.grounding}")
    print(f"latency median {np.median(res.latencies) * 1000:.0f} ms, p90 {np.percentile(res.latencies, 90) * 1000:.0f}"
          f" ms; real-time factor {res.real_time_factor:.2f}x; {sum(c.motion.num_frames for c in res.chunks)} frames")
    if report is not None:
        print(f"sent {report.sent} frames to {', '.join(str(a) for a in (engines.vmc, engines.livelink) if a)}; "
              f"dropped {report.dropped} late; {report.failed} datagrams not taken by the system")
    if out:
        print(f"wrote {res.motion().save(out)}")
    return 0
