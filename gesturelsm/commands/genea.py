"""`gesturelsm genea`: the GENEA Leaderboard's yardstick (docs/GENEA.md).

    gesturelsm genea submit SPEECH_DIR --out OUT [--samples 5] [--textgrids DIR] [generate's settings] [--cluster ...]
    gesturelsm genea metrics GENERATED_DIR HUMAN_DIR [--audio DIR] [--sem DIR] [--fgd-weights DIR] [--json FILE]

`submit` writes OUT/<speech stem>_sample<k>.npz (BEAT2's SMPL-X layout, 30 fps, a seed each) and OUT/manifest.json,
and refuses what the leaderboard would not accept. `metrics` prints the leaderboard's objective columns.
"""
from __future__ import annotations

import argparse
import contextlib
import json
from pathlib import Path

from ..cluster import add_cluster_argument, check_reachable, connect
from ..genea.submission import SAMPLES
from ..settings import DEFAULT_METHOD
from ..settings.arguments import (add_language_flag, add_max_seconds_flag, add_post_flags, add_settings_flags,
                                  add_transcribe_flag, cli_settings, input_file, input_folder, output_file,
                                  output_folder, positive, refuse)
from ..settings.values import from_text, whole_number

MAX_SAMPLES = 100
NAME = "genea"
HELP = "GENEA Leaderboard: submission folders and its objective metrics"


def add_parser(sub: argparse._SubParsersAction) -> None:
    from ..backends import SPECS
    from ..genea.files import EMAGE_FILE, MEAN_SPEED_FILE

    p = sub.add_parser(NAME, help=HELP,
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.set_defaults(func=lambda args: (p.print_help(), 0)[1])
    gsub = p.add_subparsers(dest="genea_command", metavar="COMMAND")
    s = gsub.add_parser("submit", help="K samples per speech file in BEAT2's npz layout, with a manifest",
                        description="Every speech file of SPEECH_DIR (named as its BEAT2 take, e.g. "
                        "2_scott_0_103_103.wav) -> OUT/<stem>_sample<k>.npz for k = 1..K, each with its own seed "
                        "(--seed, --seed + 1, ...), and OUT/manifest.json. Example: gesturelsm genea submit "
                        "beat2/wave16k --textgrids beat2/textgrid --out submission/")
    s.add_argument("speech_dir", metavar="SPEECH_DIR", help="folder of speech files named after their BEAT2 takes")
    s.add_argument("--out", required=True, help="submission folder (made if missing)")
    s.add_argument("--samples", type=from_text, default=SAMPLES,
                   help=f"samples per speech file; the leaderboard asks a non-deterministic system for {SAMPLES}")
    s.add_argument("--textgrids", help="folder of <stem>.TextGrid word timings (default: transcribe each speech)")
    add_transcribe_flag(s, help="audio-only: do not transcribe the speech when no --textgrids are given")
    add_language_flag(s)
    add_settings_flags(s, steps="one")
    s.add_argument("--method", default=DEFAULT_METHOD, choices=list(SPECS), help="the method to submit")
    s.add_argument("--checkpoints", help="folder with tokenizer/ and generator/ (default: shipped assets; NOT "
                   "eligible for the leaderboard, docs/GENEA.md)")
    add_post_flags(s)
    add_max_seconds_flag(s)
    add_cluster_argument(s, "each speech file (its samples)")
    s.set_defaults(func=run_submit)
    m = gsub.add_parser("metrics", help="the leaderboard's objective metrics of a folder of generated samples",
                        description="FD_g, FD_k, DIV_k, DIV_sample and DIV_pose always; BA with --audio, SRGR with "
                        "--sem, FGD with --fgd-weights, as GENEALeaderboard/objective_metric computes them "
                        "(docs/GENEA.md). Example: gesturelsm genea metrics submission/ beat2/smplxflame_30 "
                        "--audio beat2/wave16k --json metrics.json")
    m.add_argument("generated", metavar="GENERATED_DIR", help="<take>_<anything>.npz files, several per take")
    m.add_argument("human", metavar="HUMAN_DIR", help="the human motion, <take>.npz (BEAT2's smplxflame_30)")
    m.add_argument("--audio", help="folder of <take>.wav (BEAT2's wave16k), for beat alignment (BA)")
    m.add_argument("--sem", help="folder of <take>.txt semantic labels (BEAT2's sem), for SRGR")
    m.add_argument("--fgd-weights", help=f"folder with EMAGE's {EMAGE_FILE} (or the file), for FGD")
    m.add_argument("--mean-speed", help=f"BEAT2's {MEAN_SPEED_FILE} for BA (default: HUMAN_DIR/../stats/)")
    m.add_argument("--model", help="SMPL-X .npz body model for joint positions (default: the built-in mannequin; "
                   "the leaderboard uses SMPL-X 2020 neutral)")
    m.add_argument("--json", help="also write the columns to this JSON file")
    m.set_defaults(func=run_metrics)


def run_submit(args: argparse.Namespace) -> int:
    from ..backends import checkpoint_sources
    from ..genea.submit import submit

    p: list[str] = []
    settings = cli_settings(args, [args.method], p)
    samples = whole_number(from_text(args.samples), "--samples", 1, MAX_SAMPLES, p)
    max_seconds = positive(args.max_seconds, "--max-seconds", p)
    input_folder(args.speech_dir, "SPEECH_DIR", p)
    if args.textgrids:
        input_folder(args.textgrids, "--textgrids", p)
    output_folder(args.out, "--out", p)
    refuse(p)
    check_reachable(args.cluster)                # one line before anything is read or loaded
    if samples != SAMPLES:
        print(f"note: the leaderboard asks a non-deterministic system for {SAMPLES} samples per speech file; "
              f"this makes {samples}")
    with connect(args.cluster) if args.cluster else contextlib.nullcontext() as conn:
        submit(Path(args.speech_dir), Path(args.out), settings, samples=samples,
               checkpoints=checkpoint_sources(args.checkpoints), textgrids=Path(args.textgrids) if args.textgrids
               else None, max_seconds=max_seconds, connection=conn)
    return 0


def run_metrics(args: argparse.Namespace) -> int:
    from ..genea.leaderboard import EMAGE_FILE, evaluate

    p: list[str] = []
    gen = input_folder(args.generated, "GENERATED_DIR", p)
    human = input_folder(args.human, "HUMAN_DIR", p)
    audio = input_folder(args.audio, "--audio", p) if args.audio else None
    sem = input_folder(args.sem, "--sem", p) if args.sem else None
    weights = None
    if args.fgd_weights:
        w = Path(args.fgd_weights)
        weights = w if w.is_file() else w / EMAGE_FILE
        if not weights.is_file():
            p.append(f"--fgd-weights {w}: no {EMAGE_FILE} there")
    speed = input_file(args.mean_speed, "--mean-speed", p) if args.mean_speed else None
    model = input_file(args.model, "--model", p) if args.model else None
    out = output_file(args.json, "--json", ".json", p) if args.json else None
    refuse(p)
    scores = evaluate(gen, human, audio, sem, weights, body=str(model) if model else None, mean_speed=speed)
    for note in scores.notes:
        print(note)
    print(table(scores.values, f"{scores.samples} samples of {scores.takes} takes"))
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(dict(scores.values, takes=scores.takes, samples=scores.samples), indent=1) + "\n")
        print(f"wrote {out}")
    return 0


def table(values: dict, caption: str) -> str:
    """The leaderboard's columns, in its order, as a Markdown table ('-' where a column was left out)."""
    from ..genea.metrics import HEADERS, KEYS

    cells = [("-" if values.get(k) is None else f"{values[k]:.4g}") for k in KEYS]
    return "\n".join([f"| {' | '.join(HEADERS[k] for k in KEYS)} |", "|" + "---|" * len(KEYS),
                      f"| {' | '.join(cells)} |", f"({caption})"])


__all__ = ["add_parser", "run_metrics", "run_submit", "table"]
