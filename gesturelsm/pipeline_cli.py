"""`gesturelsm generate` (speech -> motion npz): the command line of the pipeline (pipeline.py), one floor above it."""
from __future__ import annotations

import argparse
import time

from .align.textgrid import read_words
from .audio import load_audio
from .constants import SAMPLE_RATE
from .motion.postprocess import DEFAULT_SMOOTHING, SMOOTHING_WINDOWS
from .backends import FACTS, checkpoint_sources
from .export.rig import export_rig
from .grounding.cli import add_grounding_flag, grounding_on
from .pipeline import GesturePipeline, finish
from .retarget import check_usable, load_character


def add_parser(sub: argparse._SubParsersAction) -> None:
    g = sub.add_parser("generate", help="generate SMPL-X gestures for a speech file")
    g.add_argument("audio", help="speech file (wav, flac, mp3, ogg, m4a ...)")
    src = g.add_mutually_exclusive_group()
    src.add_argument("--text", help="transcript; word timings are aligned automatically")
    src.add_argument("--textgrid", help="Praat TextGrid with a words tier")
    src.add_argument("--no-transcribe", action="store_true",
                     help="audio-only: do not transcribe the speech when neither --text nor --textgrid is given")
    g.add_argument("--steps", type=int, help="sampling steps (default 8; DDIM 20)")
    g.add_argument("--cfg", type=float, default=2.0, help="classifier-free guidance scale")
    g.add_argument("--seed", type=int, default=0)
    g.add_argument("--method", default="gesturelsm", choices=list(FACTS),
                   help="*_authors: the authors' released weights, after `gesturelsm import-reference` (--checkpoints)")
    g.add_argument("--checkpoints", help="folder with tokenizer/ and generator/ (default: shipped assets)")
    g.add_argument("--smoothing", default=DEFAULT_SMOOTHING, choices=list(SMOOTHING_WINDOWS),
                   help=f"post-processing (motion/postprocess.py); 'off' writes the raw model output (default {DEFAULT_SMOOTHING})")
    g.add_argument("--stand-in-place", action="store_true", help="remove horizontal root movement")
    add_grounding_flag(g)
    g.add_argument("--out", required=True, help="output .npz (BEAT2-compatible)")
    g.add_argument("--rig", help="your character (.vrm / .glb / .gltf / .bvh): also writes OUT's stem + the "
                   "character's suffix, the motion on it (docs/CHARACTERS.md)")
    g.set_defaults(func=run_generate)


def run_generate(args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    rig = load_character(args.rig) if getattr(args, "rig", None) else None     # a bad file stops before the work
    if rig is not None:
        check_usable(rig, draw=False)
    audio = load_audio(args.audio)
    words = None
    if args.textgrid:
        words = read_words(args.textgrid)
    pipe = GesturePipeline.from_pretrained(checkpoints=checkpoint_sources(args.checkpoints), methods=[args.method])
    steps = args.steps or FACTS[args.method].default_steps
    res = pipe.generate(audio, SAMPLE_RATE, words=words, text=args.text, steps=steps, cfg=args.cfg, seed=args.seed,
                        method=args.method, transcribe=not args.no_transcribe)
    motion, note = finish(res.motion, args.stand_in_place, args.smoothing, grounding_on(args))
    path = motion.save(args.out)
    if rig is not None:
        print(f"wrote {export_rig(motion, rig, path, grounding=grounding_on(args))}")
    for w in res.warnings + ([note] if note else []):
        print(f"warning: {w}")
    stages = ", ".join(f"{k} {v:.2f}s" for k, v in res.timings.items())
    print(f"{path}: {res.motion.num_frames} frames ({res.motion.duration:.1f} s) with {args.method}, {steps} steps, "
          f"CFG {args.cfg}, seed {args.seed}, smoothing {args.smoothing}, grounding {args.grounding}; {res.text_mode}")
    print(f"timings: {stages}; real-time factor {res.real_time_factor:.1f}x; total {time.perf_counter() - t0:.1f}s")
    return 0
