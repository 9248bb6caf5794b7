"""`gesturelsm sweep`: methods x steps x CFG x seeds on one speech -> table (CSV, markdown, JSON) and plot.

    gesturelsm sweep speech.wav --methods gesturelsm rectified_flow ddim --steps 1 2 4 8 --cfg 1 2 3 --seeds 2 \
        [--text "what is said" | --textgrid words.TextGrid | --no-transcribe] [--metric wrist_speed] [--grounding off] \
        --out runs/sweep
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..align.textgrid import read_words
from ..audio import SAMPLE_RATE, load_audio
from ..backends import checkpoint_sources
from ..grounding.cli import add_grounding_flag, grounding_on
from ..pipeline import GesturePipeline
from .sweep import SweepGrid, SweepLimits, check_grid, parse_numbers, run_sweep
from .sweep_report import PLOT_METRICS, markdown_text, write_sweep

LIMITS = SweepLimits()


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("sweep", help="steps x CFG x seeds on one speech: time and motion statistics, table and plot",
                       description="Generate every combination of methods, step counts and CFG scales once per seed "
                                   "from one speech (features computed once), measure each motion (docs/SWEEP.md) "
                                   "and write sweep.csv, sweep.md, sweep.json and sweep.png (a statistic against "
                                   f"generation time). Size bound: {LIMITS.describe()}.")
    p.add_argument("audio", help="speech file (wav, flac, mp3, ...)")
    p.add_argument("--methods", nargs="+", default=None, help="default: every method the checkpoints provide")
    p.add_argument("--steps", nargs="+", default=["1", "2", "4", "8"], help="sampling step counts")
    p.add_argument("--cfg", nargs="+", default=["2"], help="classifier-free guidance scales")
    p.add_argument("--seeds", type=int, default=1, help="seeds 0 .. N-1 per combination")
    src = p.add_mutually_exclusive_group()
    src.add_argument("--text", default=None, help="transcript (word timings aligned automatically)")
    src.add_argument("--textgrid", default=None, help="Praat TextGrid with a words tier")
    src.add_argument("--no-transcribe", action="store_true", help="audio-only when neither --text nor --textgrid")
    p.add_argument("--metric", default="wrist_speed", choices=PLOT_METRICS, help="the plot's statistic")
    add_grounding_flag(p)
    p.add_argument("--checkpoints", default=None, help="folder with tokenizer/ and generator/ (default: assets/)")
    p.add_argument("--max-work", type=float, default=LIMITS.max_work,
                   help="most seconds of motion to generate in all (combinations x seeds x speech seconds)")
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--out", default="runs/sweep")
    p.set_defaults(func=run_sweep_cli)


def run_sweep_cli(args: argparse.Namespace) -> int:
    import torch

    if args.threads:
        torch.set_num_threads(args.threads)
    limits = SweepLimits(LIMITS.max_cells, LIMITS.max_seeds, args.max_work)
    audio = load_audio(args.audio)
    pipe = GesturePipeline.from_pretrained(checkpoints=checkpoint_sources(args.checkpoints), methods=args.methods)
    grid = SweepGrid(tuple(dict.fromkeys(args.methods or pipe.methods)), parse_numbers(args.steps, int, "--steps"),
                     parse_numbers(args.cfg, float, "--cfg"), args.seeds)
    check_grid(pipe, grid, len(audio) / SAMPLE_RATE, limits)
    words = read_words(args.textgrid) if args.textgrid else None
    speech = pipe.prepare_speech(audio, SAMPLE_RATE, words=words, text=args.text, transcribe=not args.no_transcribe)
    result = run_sweep(pipe, speech, grid, keep_motions=False, grounding=grounding_on(args),
                       progress=lambda f, m: print(f"[{100 * f:3.0f} %] {m}", file=sys.stderr, flush=True))
    files = write_sweep(result, Path(args.out), args.metric)
    print(markdown_text(result))
    print(f"\nwrote {', '.join(str(p) for p in files.values())}")
    return 0
