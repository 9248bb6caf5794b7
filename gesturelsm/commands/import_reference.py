"""`gesturelsm import-reference DIR --out CKPT_DIR`: convert the authors' released files to our format."""
from __future__ import annotations

import argparse

NAME = "import-reference"
HELP = "convert the authors' released GestureLSM files (safely) to our checkpoints"


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(NAME, help=HELP,
                       description="Reads shortcut_reflow.bin / new_540_diffusion.bin / meanflow.pth, "
                                   "net_300000_{upper,hands,lower}.pth, vocab.pkl and mean_std/*.npy under DIR "
                                   "without executing pickled code, and writes safetensors checkpoints.")
    p.add_argument("dir", help="folder with the released files (searched recursively)")
    p.add_argument("--out", required=True, help="output checkpoint folder (use it with --checkpoints)")
    p.add_argument("--heads", type=int, default=4,
                   help="attention heads (not stored in the weights; 4 in every release)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..reference.importer import import_reference

    for path in import_reference(args.dir, args.out, heads=args.heads):
        print(f"wrote {path}")
    return 0
