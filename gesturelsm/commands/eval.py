"""`gesturelsm eval` and `gesturelsm bench`.

    gesturelsm eval --data ../shared/data/beat2 [--checkpoints assets] [--methods ...] [--steps 1 2 4 8]
                    [--cfg 2] [--seeds 2] [--emage-weights AESKConv_240_100.bin] [--smplx SMPLX.npz] --out runs/eval
                    [--cluster local|auto|ray://HOST:PORT]     (each clip a task, docs/CLUSTER.md)
    gesturelsm bench [--checkpoints assets] [--presets shipped paper] [--steps 1 2 4 8 20] [--repeats 3]
                     [--quality runs/eval/eval.json] [--data ../shared/data/beat2] --out runs/bench

Each writes <out>/<eval|bench>.json and .md (and bench.png) and prints the markdown table.
"""
from __future__ import annotations

import argparse
import contextlib
import json
from pathlib import Path

from ..backends import SPECS, checkpoint_sources, ours_default
from ..body import load_body_model
from ..cluster import add_cluster_argument, connect
from ..data.beat2 import Beat2Dataset
from ..errors import CheckpointError
from ..metrics.fgd import default_extractors
from ..pipeline import GesturePipeline
from ..settings import CLI, DEFAULT_CFG, Limits, grid_problems
from ..settings.arguments import input_file, input_folder, output_folder, refuse, threads
from ..settings.values import from_text, method_list, real_number, whole_number
from .bench import run_bench
from .clips import heldout_clips
from .evaluate import evaluate, plan_grid
from .plot import quality_time_plot
from .tables import bench_markdown, eval_markdown
from .timing import check_device


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("eval", help="paper metrics (FGD, BC vs GT, diversity, face error, time) on held-out data",
                       description="Evaluate generators on a BEAT2-layout folder's held-out clips: methods x steps x "
                                   "CFG -> markdown table (paper format) and JSON.")
    p.add_argument("--data", required=True, help="BEAT2-layout folder (smplxflame_30/, wave16k/, textgrid/)")
    p.add_argument("--checkpoints", default=None, help="folder with tokenizer/ and generator/ (default: assets/)")
    p.add_argument("--methods", nargs="+", default=None, help="default: every generator found")
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

    b = sub.add_parser("bench", help="speed / memory on this machine: per step, AITS, RTF, end to end; plot",
                       description="Time GestureLSM at several step counts against rectified flow and DDIM, shipped "
                                   "and paper-size, in one run.")
    b.add_argument("--checkpoints", default=None, help="folder with tokenizer/ and generator/ (default: assets/)")
    b.add_argument("--presets", nargs="+", default=["shipped", "paper"], choices=["shipped", "paper"],
                   help="model sizes to time: the shipped checkpoints and the paper's size")
    b.add_argument("--methods", nargs="+", default=None, help="default: every generator found")
    b.add_argument("--steps", nargs="+", default=[1, 2, 4, 8, 20], help="sampling step counts (default: 1 2 4 8 20)")
    b.add_argument("--cfg", type=from_text, default=DEFAULT_CFG, help=f"CFG scale (default: {DEFAULT_CFG:g})")
    b.add_argument("--repeats", type=from_text, default=3, help="timed runs per setting (default: 3)")
    b.add_argument("--long-seconds", type=from_text, default=60.0,
                   help="speech length for the long RTF (0: skip; default: 60)")
    b.add_argument("--long-presets", nargs="+", default=["shipped", "paper"],
                   help="presets timed on the long speech (RTF 60 s, peak memory); the paper size is slow on CPU")
    b.add_argument("--device", default="auto", help="cpu, cuda or auto (cuda when present, plus cpu)")
    b.add_argument("--threads", type=from_text, default=None, help="torch threads (default: torch's choice)")
    b.add_argument("--data", default=None, help="BEAT2-layout folder: its first audio take is the test speech "
                                                "and the end-to-end input")
    b.add_argument("--no-video", action="store_true", help="skip the end-to-end upload-to-video timing")
    b.add_argument("--quality", default=None, help="eval.json from `gesturelsm eval` for the quality axis")
    b.add_argument("--metric", default="fgd_k", choices=["fgd_k", "fgd_g", "fgd_emage"],
                   help="quality axis of the plot (from --quality)")
    b.add_argument("--from-json", default=None, help="re-make the table and plot from an earlier bench.json "
                                                     "(e.g. with a newer --quality) without timing anything")
    b.add_argument("--out", default="runs/bench", help="output folder")
    b.set_defaults(func=run_bench_cli)


def _write(out: Path, stem: str, rep: dict, md: str) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{stem}.json").write_text(json.dumps(rep, indent=1, default=float))
    (out / f"{stem}.md").write_text(md + "\n")


def _grid(args: argparse.Namespace, methods: list[str], p: list[str]) -> tuple | None:
    """(step counts, CFG scales) checked against every chosen method's spec (the settings' validator)."""
    found = grid_problems(methods, args.steps, args.cfg, 1, 1, Limits(), CLI, p)
    return None if found is None else found[:2]


def check_eval(args: argparse.Namespace) -> tuple:
    """(methods, steps, cfgs, seeds, threads): every argument before any work, all problems at once."""
    p: list[str] = []
    methods = method_list(args.methods, list(SPECS), p, "--methods") if args.methods else None
    grid = _grid(args, methods or list(SPECS), p)
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


def check_bench(args: argparse.Namespace) -> tuple:
    """(steps, cfg, repeats, long seconds, threads): every argument before any work, all problems at once."""
    p: list[str] = []
    methods = method_list(args.methods, list(SPECS), p, "--methods") if args.methods else None
    grid = _grid(args, methods or ours_default(), p)
    repeats = whole_number(args.repeats, "--repeats", 1, 1000, p)
    long_s = real_number(args.long_seconds, "--long-seconds", 0.0, 3600.0, p)
    n_threads = threads(args.threads, p)
    for flag, path in (("--quality", args.quality), ("--from-json", args.from_json)):
        if path:
            input_file(path, flag, p)
    if args.data:
        input_folder(args.data, "--data", p)
    output_folder(args.out, "--out", p)
    refuse(p)
    steps, cfgs = grid or ((), (None,))
    return steps, cfgs[0], repeats, long_s, n_threads


def run_eval(args: argparse.Namespace) -> int:
    import numpy as np
    import torch

    methods, steps, cfgs, seeds, n_threads = check_eval(args)
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
    _write(Path(args.out), "eval", rep, md)
    print(md)
    print(f"\nwrote {Path(args.out) / 'eval.json'} and eval.md")
    return 0


def run_bench_cli(args: argparse.Namespace) -> int:
    import torch

    steps, cfg, repeats, long_seconds, n_threads = check_bench(args)
    if n_threads:
        torch.set_num_threads(n_threads)
    devices = ["cpu"] + (["cuda"] if torch.cuda.is_available() else []) if args.device == "auto" else [args.device]
    for dev in devices:
        check_device(dev)                      # a clear line (exit 2) instead of a torch error mid-run
    speech, e2e = None, None
    out = Path(args.out)
    if args.data:
        ds = Beat2Dataset(args.data)
        names = ds.audio_only_names + ds.names
        if names:
            take = ds.load(names[0])
            speech = take.audio
            if not args.no_video:
                text = " ".join(w.text for w in take.words if w.end <= 10.0) if take.words else None
                e2e = {"audio": ds.wave_dir / f"{names[0]}.wav", "text": text, "out": out / "end_to_end.mp4"}
    quality = json.loads(Path(args.quality).read_text()) if args.quality else None
    reports = []
    out.mkdir(parents=True, exist_ok=True)
    if args.from_json:
        old = json.loads(Path(args.from_json).read_text())
        reports, devices = old.get("devices", [old]), []
    for dev in devices:
        rep = run_bench(args.checkpoints, tuple(args.presets), args.methods, tuple(steps), cfg,
                        repeats, dev, speech, long_seconds, e2e if dev == "cpu" else None,
                        log=lambda m: print(m, flush=True), long_presets=tuple(args.long_presets))
        reports.append(rep)
    md = "\n\n".join(bench_markdown(r) for r in reports)
    rep = reports[0] if len(reports) == 1 else {"devices": reports}
    _write(out, "bench", rep, md)
    png = quality_time_plot(reports[-1], out / "bench.png", quality, metric=args.metric)
    print(md)
    print(f"\nwrote {out / 'bench.json'}, bench.md and {png}")
    return 0
