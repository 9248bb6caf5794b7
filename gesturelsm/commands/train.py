"""`gesturelsm train`: a generator (GestureLSM or a baseline) trained over frozen tokenizers on a BEAT2-layout folder.
`gesturelsm generate` (generate.py) runs what it trained."""
from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from typing import TYPE_CHECKING

from ..constants import ASSETS, FPS, SAMPLE_RATE
from ..errors import UserError

if TYPE_CHECKING:
    from ..data.beat2 import Beat2Dataset
    from ..features.text import TextEmbedder
    from ..generator.augment import Variant
    from ..generator.data import TakeTensors
    from ..tokenizer.model import RVQVAE

NAME = "train"
HELP = "train a generator (GestureLSM or a baseline) on a BEAT2-layout folder"


def add_parser(sub: argparse._SubParsersAction) -> None:
    from ..flows import FACTS as METHODS                 # the methods' facts, in registry order
    from ..generator.variant_kinds import KINDS

    p = sub.add_parser(NAME, help=HELP,
                       description="Train a speech-to-latent generator for one sampling method (GestureLSM's "
                                   "shortcut flow or a baseline) over frozen tokenizers, on a BEAT2-layout folder.")
    p.add_argument("--data", required=True, help="BEAT2-layout folder")
    p.add_argument("--tokenizers", default=str(ASSETS / "tokenizer"),
                   help="folder of frozen <region>.safetensors (default: the shipped assets/tokenizer)")
    p.add_argument("--method", default="gesturelsm", choices=list(METHODS),
                   help="the sampling method it is trained for")
    p.add_argument("--preset", default="small", help="tiny | small (shipped) | paper")
    p.add_argument("--out", default="runs/generator", help="run folder")
    p.add_argument("--steps", type=int, default=4000, help="training steps")
    p.add_argument("--batch-size", type=int, default=32, help="windows per training step")
    p.add_argument("--lr", type=float, default=2e-4, help="learning rate")
    p.add_argument("--betas", type=float, nargs=2, default=(0.5, 0.999), metavar=("B1", "B2"), help="Adam betas")
    p.add_argument("--prediction", default="data", choices=["data", "velocity"],
                   help="flows: the network predicts clean latents x1 (default) or the velocity (the paper)")
    p.add_argument("--time-sampler", default="beta", choices=["beta", "uniform", "logit_normal"],
                   help="gesturelsm only: training-time distribution of t")
    p.add_argument("--ema-teacher", action="store_true", help="shortcut targets from the EMA network")
    p.add_argument("--seed-noise", type=float, default=0.0,
                   help="std of noise on the real seed latents in training (the rollout seeds windows with "
                        "generated ones)")
    p.add_argument("--augment", nargs="+", default=[], choices=list(KINDS), metavar="KIND",
                   help="add precomputed speech variants of each training take (off by default): tempo = speech "
                        "x0.9 / x1.1 as fast with the motion time-warped alike; pitch = +-2 semitones; "
                        "gain = +-6 dB (motion unchanged); each variant also mirrored")
    p.add_argument("--set", nargs="+", default=[], metavar="FIELD=VALUE",
                   help="override fields of the preset's GeneratorConfig, e.g. --set speech_add=true st_layers=6")
    p.add_argument("--train-fraction", type=float, default=0.8,
                   help="without a split file: the first fraction of each take is training, the rest held out")
    p.add_argument("--speakers", nargs="*", help="speaker ids or names to train on (e.g. 2 scott; default: all)")
    p.add_argument("--no-text", action="store_true", help="ignore transcripts (audio-only model)")
    p.add_argument("--seed", type=int, default=0, help="random seed of the training run")
    p.add_argument("--device", default="auto", help="auto | cpu | cuda | cuda:N; several processes (torchrun): "
                   "cpu trains with gloo, cuda with nccl and one GPU per process")
    p.add_argument("--eval-every", type=int, default=500, help="steps between held-out evaluations")
    p.add_argument("--ship", metavar="DIR", help="also write an fp16 copy as DIR/<method>.safetensors")
    p.set_defaults(func=run_train)


def run_train(args: argparse.Namespace) -> int:
    import torch

    from ..data.beat2 import Beat2Dataset
    from ..features.text import TextEmbedder
    from ..generator.augment import variants_for
    from ..generator.distributed import check_launch
    from ..generator.train import GenTrainConfig, train_generator
    from ..motion.regions import GENERATED_REGIONS
    from ..tokenizer.model import RVQVAE

    check_launch(args.device)              # refuse e.g. more torchrun processes than GPUs before loading anything
    tok_dir = Path(args.tokenizers)
    missing = [r for r in GENERATED_REGIONS if not (tok_dir / f"{r}.safetensors").exists()]
    if missing:
        raise UserError(f"{tok_dir}: no tokenizer for {', '.join(missing)} (train them with train-tokenizer)")
    tokenizers = {r: RVQVAE.load(tok_dir / f"{r}.safetensors") for r in GENERATED_REGIONS}
    ds = Beat2Dataset(args.data, speakers=args.speakers)
    emb = None if args.no_text else TextEmbedder.shared()
    if emb is not None and not emb.available:
        print(f"warning: {emb.error}; training audio-only")
        emb = None
    variants = variants_for(args.augment)
    train, held = training_takes(ds, tokenizers, emb, args.train_fraction, variants)
    if not train:
        raise UserError(f"{args.data}: no usable training takes (motion + audio)")
    config = preset_with(args.preset, args.set)
    tc = GenTrainConfig(method=args.method, preset=args.preset, steps=args.steps, batch_size=args.batch_size,
                        lr=args.lr, betas=tuple(args.betas), prediction=args.prediction,
                        time_sampler=args.time_sampler, ema_teacher=args.ema_teacher, seed=args.seed,
                        seed_noise=args.seed_noise,
                        eval_every=args.eval_every, save_every=args.eval_every, device=args.device)
    out = Path(args.out) / f"{args.method}.safetensors"
    policy = "train_test_split.csv" if ds.splits else f"first {round(args.train_fraction * 100)}% of each take"
    meta = {"data": policy, "takes": ds.names} | ({"augment": [v.name for v in variants]} if variants else {})
    if variants:
        print(f"augmentation: {len(train)} training takes ({', '.join(v.name for v in variants)}, each mirrored)")
    model = train_generator(train, held, tokenizers, tc, out, config=config, meta=meta)
    if args.ship and (not torch.distributed.is_initialized() or torch.distributed.get_rank() == 0):
        path = model.save(Path(args.ship) / f"{args.method}.safetensors", half=True,
                          meta={**meta, "steps": tc.steps, "preset": tc.preset, "train": tc.__dict__})
        print(f"shipped {path} ({path.stat().st_size / 1e6:.1f} MB)")
    return 0


def training_takes(ds: Beat2Dataset, tokenizers: dict[str, RVQVAE], emb: TextEmbedder | None, train_fraction: float,
                   variants: Sequence[Variant] = ()) -> tuple[list[TakeTensors], list[TakeTensors]]:
    """(training, held-out) tensors of every take with motion and audio: the split file's parts, or the first
    `train_fraction` of each take for training and the rest held out. Training takes come as [take, mirror]
    per take, then 2 per augmentation variant (none by default, which keeps the list and so the batches exact)."""
    from ..align.words import Word
    from ..generator.augment import augmented_takes
    from ..generator.data import build_take

    train, held = [], []
    for name in ds.names:
        take = ds.load(name)
        if take.audio is None:
            print(f"warning: {name} has no audio; skipped")
            continue
        feats = take.motion.to_features()
        if ds.splits:
            part = ds.splits.get(name)
            dest = train if part == "train" else held if part in ("val", "test") else None
            if dest is None:
                continue
            dest.append(build_take(name, feats, take.audio, take.words, tokenizers, emb))
            if part == "train":
                train.append(build_take(name, feats, take.audio, take.words, tokenizers, emb, mirror=True))
                train.extend(augmented_takes(name, take.motion, take.audio, take.words, tokenizers, emb, variants))
            continue
        cut = int(round(train_fraction * feats.shape[0])) // 4 * 4
        a_cut = int(round(cut * SAMPLE_RATE / FPS))
        words_tr = take.words
        train.append(build_take(name, feats[:cut], take.audio[:a_cut], words_tr, tokenizers, emb))
        train.append(build_take(name, feats[:cut], take.audio[:a_cut], words_tr, tokenizers, emb, mirror=True))
        train.extend(augmented_takes(name, take.motion.slice(0, cut), take.audio[:a_cut], words_tr, tokenizers, emb,
                                     variants))
        held_words = None
        if take.words is not None:
            t0 = cut / FPS
            held_words = [Word(w.text, w.start - t0, w.end - t0) for w in take.words if w.end > t0]
        held.append(build_take(name, feats[cut:], take.audio[a_cut:], held_words, tokenizers, emb))
    return train, held


def preset_with(preset: str, overrides: list[str]):
    """A named GeneratorConfig preset with FIELD=VALUE overrides (values parsed as the field's type)."""
    import dataclasses

    from ..generator.config import PRESETS

    if preset not in PRESETS:
        raise UserError(f"unknown preset {preset!r}; choose from {', '.join(PRESETS)}")
    base = PRESETS[preset]
    defaults = {f.name: getattr(base, f.name) for f in dataclasses.fields(base)}
    fields = {k: type(v) for k, v in defaults.items()}
    changes = {}
    for item in overrides:
        key, sep, val = item.partition("=")
        if not sep or key not in fields:
            raise UserError(f"--set {item!r}: expected FIELD=VALUE with FIELD one of {', '.join(fields)}")
        kind = fields[key]
        try:
            if kind is bool:
                if val.lower() not in ("true", "false", "1", "0", "yes", "no"):
                    raise ValueError(val)
                changes[key] = val.lower() in ("true", "1", "yes")
            elif kind is tuple:                                       # elements typed like the default's
                item_kind = type(defaults[key][0]) if defaults[key] else str
                changes[key] = tuple(item_kind(v) for v in val.split(","))
            else:
                changes[key] = kind(val)
        except ValueError:
            raise UserError(f"--set {item!r}: {val!r} is not a valid {kind.__name__}") from None
    return dataclasses.replace(base, **changes)
