"""`gesturelsm train-tokenizer`: the per-region RVQ-VAE tokenizers, trained on a BEAT2-layout folder."""
from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import UserError


NAME = "train-tokenizer"
HELP = "train the per-region RVQ-VAE tokenizers on a BEAT2-layout folder"


def add_parser(sub: argparse._SubParsersAction) -> None:
    from ..motion.regions import GENERATED_REGIONS

    p = sub.add_parser(NAME, help=HELP,
                       description="Train one RVQ-VAE motion tokenizer per body region on a BEAT2-layout folder's "
                                   "training share; checkpoints and resume state go to the run folder.")
    p.add_argument("--data", required=True, help="BEAT2-layout folder (smplxflame_30/ ...)")
    p.add_argument("--out", default="runs/tokenizer", help="run folder (checkpoints, resume state)")
    p.add_argument("--regions", nargs="+", default=list(GENERATED_REGIONS), choices=list(GENERATED_REGIONS),
                   help="the body regions to train a tokenizer for")
    p.add_argument("--preset", default="small", help="tiny | small (shipped) | paper")
    p.add_argument("--steps", type=int, default=3000, help="training steps")
    p.add_argument("--batch-size", type=int, default=64, help="windows per training step")
    p.add_argument("--window", type=int, default=64, help="frames per training crop (multiple of 4)")
    p.add_argument("--lr", type=float, default=2e-4, help="learning rate")
    p.add_argument("--train-fraction", type=float, default=0.8,
                   help="without train_test_split.csv: the first fraction of every take trains")
    p.add_argument("--speakers", nargs="*", help="speaker ids or names to use")
    p.add_argument("--seed", type=int, default=0, help="random seed of the training run")
    p.add_argument("--device", default="auto", help="auto | cpu | cuda")
    p.add_argument("--eval-every", type=int, default=500, help="steps between held-out evaluations")
    p.add_argument("--ship", metavar="DIR", help="also write fp16 inference copies here (e.g. assets/tokenizer)")
    p.add_argument("--decoder-only", metavar="DIR",
                   help="fine-tune only the decoders of the tokenizers in DIR (<region>.safetensors), encoder and "
                        "codebooks frozen so generators trained on them stay valid; writes --out/<region>.safetensors")
    p.add_argument("--accel-weight", type=float, default=None,
                   help="with --decoder-only: weight of the L1 loss on the second difference (jitter), default 2")
    p.set_defaults(func=run_train)


def run_train(args: argparse.Namespace) -> int:
    from ..data.split import split_features
    from ..tokenizer.train import TrainConfig, train_region

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
    if args.decoder_only:
        return run_tune_decoder(args, split, cfg, out)
    if args.accel_weight is not None:
        raise UserError("--accel-weight is used with --decoder-only (a full training run takes the preset's losses)")
    for region in args.regions:
        model = train_region(region, split, cfg, out)
        if args.ship:
            path = model.cpu().save(Path(args.ship) / f"{region}.safetensors", half=True,
                                    meta={"data": split.policy, "steps": cfg.steps, "preset": cfg.preset})
            print(f"shipped {path} ({path.stat().st_size / 1e6:.1f} MB)")
    return 0


def run_tune_decoder(args: argparse.Namespace, split, cfg, out: Path) -> int:
    from ..checkpoint import load_checkpoint
    from ..tokenizer.model import KIND, RVQVAE
    from ..tokenizer.train import tune_decoder

    src = Path(args.decoder_only)
    missing = [r for r in args.regions if not (src / f"{r}.safetensors").exists()]
    if missing:
        raise UserError(f"{src}: no tokenizer checkpoint for {', '.join(missing)} (expected <region>.safetensors)")
    weight = 2.0 if args.accel_weight is None else args.accel_weight
    if weight < 0:
        raise UserError(f"--accel-weight must be >= 0 (got {weight})")
    out.mkdir(parents=True, exist_ok=True)
    for region in args.regions:
        model = RVQVAE.load(src / f"{region}.safetensors")
        if model.region != region:
            raise UserError(f"{src / f'{region}.safetensors'} holds the {model.region!r} tokenizer, not {region!r}")
        _, meta = load_checkpoint(src / f"{region}.safetensors", KIND)
        meta = {k: v for k, v in meta.items() if k not in ("kind", "config", "region")}   # keep how it was trained
        model = tune_decoder(model, split, cfg, weight)
        meta["decoder_tuning"] = {"data": split.policy, "steps": cfg.steps, "accel_weight": weight, "lr": cfg.lr,
                                  "batch_size": cfg.batch_size, "window": cfg.window}
        model.save(out / f"{region}.safetensors", meta=meta)
        if args.ship:
            path = model.save(Path(args.ship) / f"{region}.safetensors", half=True, meta=meta)
            print(f"shipped {path} ({path.stat().st_size / 1e6:.1f} MB)")
    return 0
