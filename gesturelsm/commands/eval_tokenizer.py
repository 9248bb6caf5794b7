"""`gesturelsm eval-tokenizer`: held-out reconstruction quality of trained tokenizers, per region."""
from __future__ import annotations

import argparse
from pathlib import Path

from ..constants import ASSETS

NAME = "eval-tokenizer"
HELP = "held-out reconstruction quality of trained tokenizers"


def add_parser(sub: argparse._SubParsersAction) -> None:
    e = sub.add_parser(NAME, help=HELP,
                       description="Encode and decode a BEAT2-layout folder's held-out motion with trained "
                                   "tokenizers and report the reconstruction error per region.")
    e.add_argument("--data", required=True, help="BEAT2-layout folder")
    e.add_argument("--ckpt", default=str(ASSETS / "tokenizer"),
                   help="folder with <region>.safetensors (default: shipped)")
    e.add_argument("--train-fraction", type=float, default=0.8,
                   help="without a split file: the first fraction of each take is training, the rest held out")
    e.add_argument("--model", help="body model for joint positions (default: built-in mannequin)")
    e.add_argument("--json", help="also write the numbers as JSON here")
    e.set_defaults(func=run_eval)


def run_eval(args: argparse.Namespace) -> int:
    from ..tokenizer.evaluate import evaluate_folder, format_report

    report = evaluate_folder(args.data, args.ckpt, args.train_fraction, args.model)
    print(format_report(report))
    if args.json:
        import json

        Path(args.json).write_text(json.dumps(report, indent=2))
    return 0
