"""`gesturelsm eval`: the paper's metrics of generators on a BEAT2-layout folder's held-out clips.

    gesturelsm eval --data ../shared/data/beat2 [--checkpoints assets] [--methods ...] [--steps 1 2 4 8]
                    [--cfg 2] [--seeds 2] [--emage-weights AESKConv_240_100.bin] [--smplx SMPLX.npz] --out runs/eval
                    [--cluster local|auto|ray://HOST:PORT]     (each clip a task, docs/CLUSTER.md)

It writes <out>/eval.json and eval.md and prints the markdown table (`gesturelsm bench`: bench.py).
"""
from __future__ import annotations

import argparse
import contextlib
import json
from pathlib import Path

from ..cluster import add_cluster_argument, check_reachable, connect
from ..errors import CheckpointError
from ..settings import CLI, DEFAULT_CFG, Limits, grid_problems
from ..settings.arguments import add_methods_flag, input_file, input_folder, output_folder, refuse, threads
from ..settings.values import from_text, method_list, real_number, whole_number

NAME = "eval"
HELP = "paper metrics (FGD, BC vs GT, diversity, face error, time) on held-out data"


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(NAME, help=HELP,
                       description="Evaluate generators on a BEAT2-layout folder's held-out clips: methods x steps x "
                                   "CFG -> markdown table (paper format) and JSON.")
    p.add_argument("--data", required=True, help="BEAT2-layout folder (smplxflame_30/, wave16k/, textgrid/)")
    p.add_argument("--checkpoints", default=None, help="folder with tokenizer/ and generator/ (default: assets/)")
    add_methods_flag(p)
    p.add_argument("--steps", nargs="+", default=[1, 2, 4, 8], help="sampling step counts (default: 1 2 4 8)")
    p.add_argument("--cfg", nargs="+", default=[DEFAULT_CFG], help=f"CFG scales (default: {DEFAULT_CFG:g})")
    p.add_argument("--seeds", type=from_text, default=2, help="seeds per clip and setting (default: 2)")
    p.add_argument("--train-fraction", type=from_text, default=0.8,
                   help="without a split file: held out = the rest (default: 0.8)")
    p.add_argument("--no-audio-only", action="store_true", help="skip takes that have speech but no motion")
    p.add_argument("--max-clips", type=from_text, default=None, help="at most this many clips (default: all)")
    p.add_argument("--emage-weights", default=None, help="EMAGE's AESKConv_240_100.bin: adds the paper's FGD")
    p.add_argument("--smplx", default=None, help="a real SMPL-X model: joints from it, plus face vertex MSE")
    p.add_argument("--mean-speed", default=None, help="(55,) .npy of per-joint mean speeds (m/s) for BC; default: "
                                                      "DATA/stats/mean_vel_smplxflame_30.npy if present, else the "
                                                      "ground truth's own")
    p.add_argument("--threads", type=from_text, default=None, help="torch threads (default: torch's choice)")
    p.add_argument("--out", default="runs/eval", help="output folder")
    add_cluster_argument(p, "each held-out clip (every method, setting and seed on it)")
    p.set_defaults(func=run_eval)


def write_report(out: Path, stem: str, rep: dict, md: str) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{stem}.json").write_text(json.dumps(rep, indent=1, default=float))
    (out / f"{stem}.md").write_text(md + "\n")


def checked_grid(args: argparse.Namespace, methods: list[str], p: list[str]) -> tuple | None:
    """(step counts, CFG scales) checked against every chosen method's spec (the settings' validator)."""
    found = grid_problems(methods, args.steps, args.cfg, 1, 1, Limits(), CLI, p)
    return None if found is None else found[:2]


def check_eval(args: argparse.Namespace) -> tuple:
    """(methods, steps, cfgs, seeds, threads): every argument before any work, all problems at once."""
    from ..backends import SPECS

    p: list[str] = []
    methods = method_list(args.methods, list(SPECS), p, "--methods") if args.methods else None
    grid = checked_grid(args, methods or list(SPECS), p)
    seeds = whole_number(args.seeds, "--seeds", 1, 100, p)
    n_threads = threads(args.threads, p)
    real_number(args.train_fraction, "--train-fraction", 0.0, 1.0, p)
    if args.max_clips is not None:
        whole_number(args.max_clips, "--max-clips", 1, 10 ** 6, p)
    input_folder(args.data, "--data", p)
    for flag, path in (("--emage-weights", args.emage_weights), ("--smplx", args.smplx),
                       ("--mean-speed", args.mean_speed)):
        if path:
            input_file(path, flag, p)
    output_folder(args.out, "--out", p)
    refuse(p)
    return methods, *grid, seeds, n_threads


def run_eval(args: argparse.Namespace) -> int:
    import numpy as np
    import torch

    from ..backends import checkpoint_sources
    from ..body import load_body_model
    from ..evaluation.clips import heldout_clips
    from ..evaluation.evaluate import evaluate, plan_grid
    from ..evaluation.tables import eval_markdown
    from ..metrics.fgd import default_extractors
    from ..pipeline import GesturePipeline

    methods, steps, cfgs, seeds, n_threads = check_eval(args)
    check_reachable(args.cluster)                # before the clips are read and the models load
    if n_threads:
        torch.set_num_threads(n_threads)
    clips, policy = heldout_clips(args.data, args.train_fraction, audio_only=not args.no_audio_only,
                                  max_clips=args.max_clips)
    pipe = GesturePipeline.from_pretrained(checkpoints=checkpoint_sources(args.checkpoints), methods=args.methods)
    methods = methods or pipe.methods
    missing = [m for m in methods if m not in pipe.methods]
    if missing:
        raise CheckpointError(f"no checkpoint for {', '.join(missing)}; available: {', '.join(pipe.methods)}")
    for m in methods:
        for s in steps:
            for c in cfgs:
                pipe.check_settings(m, s, c)
    body = load_body_model(args.smplx)
    stats = Path(args.data) / "stats" / "mean_vel_smplxflame_30.npy"      # BEAT2's own, as the reference uses
    ms_path = Path(args.mean_speed) if args.mean_speed else (stats if stats.exists() else None)
    mean_speed = np.load(ms_path) if ms_path else None
    with connect(args.cluster) if args.cluster else contextlib.nullcontext() as conn:
        rep = evaluate(pipe, clips, plan_grid(methods, steps, cfgs), seeds=seeds, body=body,
                       extractors=default_extractors(args.emage_weights), mean_speed=mean_speed,
                       face_vertices=bool(args.smplx), log=lambda m: print(m, flush=True), connection=conn,
                       checkpoints=checkpoint_sources(args.checkpoints))
    rep.update({"policy": policy, "data": str(args.data), "checkpoints": str(args.checkpoints or "assets"),
                "face_vertices": bool(args.smplx), "body": str(body.path),
                "bc_mean_speed": str(ms_path) if ms_path else "ground truth's own per-joint mean speed"})
    md = eval_markdown(rep)
    write_report(Path(args.out), "eval", rep, md)
    print(md)
    print(f"\nwrote {Path(args.out) / 'eval.json'} and eval.md")
    return 0
