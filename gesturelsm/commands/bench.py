"""`gesturelsm bench`: speed and memory on this machine (per step, AITS, RTF, end to end) and a quality-time plot.

    gesturelsm bench [--checkpoints assets] [--presets shipped paper] [--steps 1 2 4 8 20] [--repeats 3]
                     [--quality runs/eval/eval.json] [--data ../shared/data/beat2] --out runs/bench

It writes <out>/bench.json, bench.md and bench.png and prints the markdown table.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from ..settings import DEFAULT_CFG
from ..settings.arguments import add_methods_flag, input_file, input_folder, output_folder, refuse, threads
from ..settings.values import from_text, method_list, real_number, whole_number
from .eval import checked_grid, write_report

NAME = "bench"
HELP = "speed / memory on this machine: per step, AITS, RTF, end to end; plot"


def add_parser(sub: argparse._SubParsersAction) -> None:
    b = sub.add_parser(NAME, help=HELP,
                       description="Time GestureLSM at several step counts against rectified flow and DDIM, shipped "
                                   "and paper-size, in one run.")
    b.add_argument("--checkpoints", default=None, help="folder with tokenizer/ and generator/ (default: assets/)")
    b.add_argument("--presets", nargs="+", default=["shipped", "paper"], choices=["shipped", "paper"],
                   help="model sizes to time: the shipped checkpoints and the paper's size")
    add_methods_flag(b)
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


def check_bench(args: argparse.Namespace) -> tuple:
    """(steps, cfg, repeats, long seconds, threads): every argument before any work, all problems at once."""
    from ..backends import SPECS, ours_default

    p: list[str] = []
    methods = method_list(args.methods, list(SPECS), p, "--methods") if args.methods else None
    grid = checked_grid(args, methods or ours_default(), p)
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


def run_bench_cli(args: argparse.Namespace) -> int:
    import torch

    from ..data.beat2 import Beat2Dataset
    from ..evaluation.bench import run_bench
    from ..evaluation.plot import quality_time_plot
    from ..evaluation.tables import bench_markdown
    from ..evaluation.timing import check_device

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
    write_report(out, "bench", rep, md)
    png = quality_time_plot(reports[-1], out / "bench.png", quality, metric=args.metric)
    print(md)
    print(f"\nwrote {out / 'bench.json'}, bench.md and {png}")
    return 0
