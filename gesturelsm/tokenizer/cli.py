"""`gesturelsm train-tokenizer` and `gesturelsm eval-tokenizer`."""
from __future__ import annotations

import argparse
from pathlib import Path

from ..constants import ASSETS
from ..data.split import split_features
from ..errors import UserError
from ..motion.regions import GENERATED_REGIONS
from .evaluate import evaluate_folder, format_report
from .train import TrainConfig, train_region


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("train-tokenizer", help="train the per-region RVQ-VAE tokenizers on a BEAT2-layout folder")
    p.add_argument("--data", required=True, help="BEAT2-layout folder (smplxflame_30/ ...)")
    p.add_argument("--out", default="runs/tokenizer", help="run folder (checkpoints, resume state)")
    p.add_argument("--regions", nargs="+", default=list(GENERATED_REGIONS), choices=list(GENERATED_REGIONS))
    p.add_argument("--preset", default="small", help="tiny | small (shipped) | paper")
    p.add_argument("--steps", type=int, default=3000)
    p.add_argument("--batch-size", type=int, default=64)
    p.add_argument("--window", type=int, default=64, help="frames per training crop (multiple of 4)")
    p.add_argument("--lr", type=float, default=2e-4)
    p.add_argument("--train-fraction", type=float, default=0.8,
                   help="without train_test_split.csv: the first fraction of every take trains")
    p.add_argument("--speakers", nargs="*", help="speaker ids or names to use")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--device", default="auto", help="auto | cpu | cuda")
    p.add_argument("--eval-every", type=int, default=500)
    p.add_argument("--ship", metavar="DIR", help="also write fp16 inference copies here (e.g. assets/tokenizer)")
    p.set_defaults(func=run_train)

    e = sub.add_parser("eval-tokenizer", help="held-out reconstruction quality of trained tokenizers")
    e.add_argument("--data", required=True, help="BEAT2-layout folder")
    e.add_argument("--ckpt", default=str(ASSETS / "tokenizer"), help="folder with <region>.safetensors (default: shipped)")
    e.add_argument("--train-fraction", type=float, default=0.8)
    e.add_argument("--model", help="body model for joint positions (default: built-in mannequin)")
    e.add_argument("--json", help="also write the numbers as JSON here")
    e.set_defaults(func=run_eval)


def run_train(args: argparse.Namespace) -> int:
    if args.window % 4:
        raise UserError(f"--window must be a multiple of 4 (got {args.window})")
    if args.steps <= 0 or args.batch_size <= 0:
        raise UserError("--steps and --batch-size must be positive")
    split = split_features(args.data, args.train_fraction, args.speakers)
    print(f"data: {split.policy}; {sum(t.shape[0] for t in split.train)} training frames, "
          f"{sum(t.shape[0] for t in split.heldout)} held-out frames")
    cfg = TrainConfig(preset=args.preset, regions=tuple(args.regions), steps=args.steps, batch_size=args.batch_size,
                      window=args.window, lr=args.lr, seed=args.seed, eval_every=args.eval_every, device=args.device)
    out = Path(args.out)
    for region in args.regions:
        model = train_region(region, split, cfg, out)
        if args.ship:
            path = model.cpu().save(Path(args.ship) / f"{region}.safetensors", half=True,
                                    meta={"data": split.policy, "steps": cfg.steps, "preset": cfg.preset})
            print(f"shipped {path} ({path.stat().st_size / 1e6:.1f} MB)")
    return 0


def run_eval(args: argparse.Namespace) -> int:
    report = evaluate_folder(args.data, args.ckpt, args.train_fraction, args.model)
    print(format_report(report))
    if args.json:
        import json

        Path(args.json).write_text(json.dumps(report, indent=2))
    return 0
