"""`gesturelsm sweep`: methods x steps x CFG x seeds on one speech -> table (CSV, markdown, JSON) and plot.

    gesturelsm sweep speech.wav --methods gesturelsm rectified_flow ddim --steps 1 2 4 8 --cfg 1 2 3 --seeds 2 \
        [--text "what is said" | --textgrid words.TextGrid | --no-transcribe] [--metric wrist_speed] [--grounding off] \
        --out runs/sweep [--cluster local|auto|ray://HOST:PORT]   (each cell and seed a task, docs/CLUSTER.md)
"""
from __future__ import annotations

import argparse
import contextlib
import sys
from dataclasses import replace

from ..cluster import add_cluster_argument, check_reachable, connect
from ..constants import SAMPLE_RATE
from ..progress import Line
from ..settings.arguments import (add_grounding_flag, add_language_flag, add_max_seconds_flag, add_methods_flag,
                                  add_transcribe_flag, input_file, output_folder, positive, refuse, threads)
from ..settings.check import CLI
from ..settings.values import from_text

say = Line()                    # the progress on stderr: the speech's steps, then the motions (a counted series)
NAME = "sweep"
HELP = "steps x CFG x seeds on one speech: time and motion statistics, table and plot"


def add_parser(sub: argparse._SubParsersAction) -> None:
    from ..evaluation.sweep_limits import DEFAULT_CFGS, DEFAULT_STEPS, PLOT_METRICS, SweepLimits

    limits = SweepLimits()
    p = sub.add_parser(NAME, help=HELP,
                       description="Generate every combination of methods, step counts and CFG scales once per seed "
                                   "from one speech (features computed once), measure each motion (docs/SWEEP.md) "
                                   "and write sweep.csv, sweep.md, sweep.json and sweep.png (a statistic against "
                                   f"generation time). Size bound: {limits.describe()}.")
    p.add_argument("audio", help="speech file (wav, flac, mp3, ...)")
    add_methods_flag(p, help="default: every method the checkpoints provide")
    p.add_argument("--steps", nargs="+", default=list(DEFAULT_STEPS),
                   help=f"sampling step counts (default: {' '.join(map(str, DEFAULT_STEPS))})")
    p.add_argument("--cfg", nargs="+", default=list(DEFAULT_CFGS),
                   help=f"classifier-free guidance scales (default: {' '.join(f'{c:g}' for c in DEFAULT_CFGS)})")
    p.add_argument("--seeds", type=from_text, default=1, help="seeds 0 .. N-1 per combination (default: 1)")
    src = p.add_mutually_exclusive_group()
    src.add_argument("--text", default=None, help="transcript (word timings aligned automatically)")
    src.add_argument("--textgrid", default=None, help="Praat TextGrid with a words tier")
    add_transcribe_flag(src, help="audio-only when neither --text nor --textgrid")
    add_language_flag(p)
    p.add_argument("--metric", default="wrist_speed", choices=PLOT_METRICS, help="the plot's statistic")
    add_grounding_flag(p)
    p.add_argument("--checkpoints", default=None, help="folder with tokenizer/ and generator/ (default: assets/)")
    p.add_argument("--max-work", type=from_text, default=limits.max_work,
                   help="most seconds of motion to generate in all (combinations x seeds x speech seconds)")
    add_max_seconds_flag(p)
    p.add_argument("--threads", type=from_text, default=None, help="torch threads (default: torch's choice)")
    p.add_argument("--out", default="runs/sweep", help="output folder")
    add_cluster_argument(p, "each combination and seed")
    p.set_defaults(func=run_sweep_cli)


def run_sweep_cli(args: argparse.Namespace) -> int:
    import torch

    from ..align.textgrid import read_words
    from ..audio import load_audio
    from ..backends import SPECS, checkpoint_sources
    from ..evaluation.sweep import SweepLimits, check_grid, run_sweep, sweep_problems
    from ..evaluation.sweep_limits import sweep_settings
    from ..evaluation.sweep_report import markdown_text, write_sweep
    from ..pipeline import GesturePipeline

    limits = SweepLimits()

    p: list[str] = []
    # the settings part by the settings' validator (the flags --methods, --grounding, --no-transcribe, --language have;
    # the named methods' bounds, or every method's when none are named: each may be loaded), then the grid's lists
    values = {s.name: s.from_cli(getattr(args, s.dest)) for s in sweep_settings() if hasattr(args, s.dest)}
    settings, grid = sweep_problems({**values, "methods": args.methods or list(SPECS)}, args.steps, args.cfg,
                                    args.seeds, list(SPECS), names=CLI, problems=p)
    n_threads = threads(args.threads, p)
    max_work = positive(args.max_work, "--max-work", p)
    max_seconds = positive(args.max_seconds, "--max-seconds", p)
    audio_path = input_file(args.audio, "AUDIO", p)
    textgrid = input_file(args.textgrid, "--textgrid", p) if args.textgrid else None
    out = output_folder(args.out, "--out", p)
    refuse(p)
    check_reachable(args.cluster)                # before the speech is read and the models load
    if n_threads:
        torch.set_num_threads(n_threads)
    audio = load_audio(audio_path, max_seconds=max_seconds)
    pipe = GesturePipeline.from_pretrained(checkpoints=checkpoint_sources(args.checkpoints), methods=args.methods,
                                           max_seconds=max_seconds)
    grid = replace(grid, methods=tuple(dict.fromkeys(args.methods or pipe.methods)))
    check_grid(pipe, grid, len(audio) / SAMPLE_RATE, SweepLimits(limits.max_cells, limits.max_seeds, max_work))
    words = read_words(textgrid) if textgrid else None
    speech = pipe.prepare_speech(audio, SAMPLE_RATE, words=words, text=args.text, transcribe=settings.transcribe,
                                 progress=say, language=settings.language)
    if speech.transcript:
        print(f'recognised: "{speech.transcript}"', file=sys.stderr, flush=True)
    with connect(args.cluster) if args.cluster else contextlib.nullcontext() as conn:
        result = run_sweep(pipe, speech, grid, keep_motions=False, grounding=settings.post.grounding,
                           progress=say, connection=conn,
                           checkpoints=checkpoint_sources(args.checkpoints))
    files = write_sweep(result, out, args.metric)
    print(markdown_text(result))
    print(f"\nwrote {', '.join(str(f) for f in files.values())}")
    return 0
