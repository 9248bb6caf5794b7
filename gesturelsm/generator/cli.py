"""`gesturelsm train` (generator) and `gesturelsm generate` (speech -> motion npz)."""
from __future__ import annotations

import argparse
from pathlib import Path

from ..flows import DEFAULT_STEPS, METHODS

AUTHORS_STEPS = {"gesturelsm_authors": 2, "meanflow_authors": 1, "diffusion_authors": 20}  # released configs

ASSETS = Path(__file__).resolve().parents[2] / "assets"


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("train", help="train a generator (GestureLSM or a baseline) on a BEAT2-layout folder")
    p.add_argument("--data", required=True, help="BEAT2-layout folder")
    p.add_argument("--tokenizers", default=str(ASSETS / "tokenizer"), help="folder of frozen <region>.safetensors")
    p.add_argument("--method", default="gesturelsm", choices=list(METHODS))
    p.add_argument("--preset", default="small", help="tiny | small (shipped) | paper")
    p.add_argument("--out", default="runs/generator", help="run folder")
    p.add_argument("--steps", type=int, default=4000)
    p.add_argument("--batch-size", type=int, default=32)
    p.add_argument("--lr", type=float, default=2e-4)
    p.add_argument("--betas", type=float, nargs=2, default=(0.5, 0.999), metavar=("B1", "B2"), help="Adam betas")
    p.add_argument("--prediction", default="data", choices=["data", "velocity"],
                   help="flows: the network predicts clean latents x1 (default) or the velocity (the paper)")
    p.add_argument("--time-sampler", default="beta", choices=["beta", "uniform", "logit_normal"],
                   help="gesturelsm only: training-time distribution of t")
    p.add_argument("--ema-teacher", action="store_true", help="shortcut targets from the EMA network")
    p.add_argument("--set", nargs="+", default=[], metavar="FIELD=VALUE",
                   help="override fields of the preset's GeneratorConfig, e.g. --set speech_add=true st_layers=6")
    p.add_argument("--train-fraction", type=float, default=0.8)
    p.add_argument("--speakers", nargs="*")
    p.add_argument("--no-text", action="store_true", help="ignore transcripts (audio-only model)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--device", default="auto")
    p.add_argument("--eval-every", type=int, default=500)
    p.add_argument("--ship", metavar="DIR", help="also write an fp16 copy as DIR/<method>.safetensors")
    p.set_defaults(func=run_train)

    g = sub.add_parser("generate", help="generate SMPL-X gestures for a speech file")
    g.add_argument("audio", help="speech file (wav, flac, mp3, ogg, m4a ...)")
    src = g.add_mutually_exclusive_group()
    src.add_argument("--text", help="transcript; word timings are aligned automatically")
    src.add_argument("--textgrid", help="Praat TextGrid with a words tier")
    g.add_argument("--steps", type=int, help="sampling steps (default 8; DDIM 20)")
    g.add_argument("--cfg", type=float, default=2.0, help="classifier-free guidance scale")
    g.add_argument("--seed", type=int, default=0)
    g.add_argument("--method", default="gesturelsm", choices=list(METHODS) + list(AUTHORS_STEPS),
                   help="*_authors: the authors' released weights, after `gesturelsm import-reference` (--checkpoints)")
    g.add_argument("--checkpoints", help="folder with tokenizer/ and generator/ (default: shipped assets)")
    g.add_argument("--out", required=True, help="output .npz (BEAT2-compatible)")
    g.set_defaults(func=run_generate)


def run_train(args: argparse.Namespace) -> int:
    import torch

    from ..cli import UserError
    from ..data.beat2 import Beat2Dataset
    from ..features.text import TextEmbedder
    from ..motion.regions import GENERATED_REGIONS
    from ..tokenizer.model import RVQVAE
    from .data import build_take
    from .train import GenTrainConfig, train_generator

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
            continue
        cut = int(round(args.train_fraction * feats.shape[0])) // 4 * 4
        a_cut = int(round(cut * 16000 / 30))
        words_tr = take.words
        train.append(build_take(name, feats[:cut], take.audio[:a_cut], words_tr, tokenizers, emb))
        train.append(build_take(name, feats[:cut], take.audio[:a_cut], words_tr, tokenizers, emb, mirror=True))
        held_words = None
        if take.words is not None:
            from ..align.words import Word

            t0 = cut / 30
            held_words = [Word(w.text, w.start - t0, w.end - t0) for w in take.words if w.end > t0]
        held.append(build_take(name, feats[cut:], take.audio[a_cut:], held_words, tokenizers, emb))
    if not train:
        raise UserError(f"{args.data}: no usable training takes (motion + audio)")
    config = preset_with(args.preset, args.set)
    tc = GenTrainConfig(method=args.method, preset=args.preset, steps=args.steps, batch_size=args.batch_size,
                        lr=args.lr, betas=tuple(args.betas), prediction=args.prediction,
                        time_sampler=args.time_sampler, ema_teacher=args.ema_teacher, seed=args.seed,
                        eval_every=args.eval_every, save_every=args.eval_every, device=args.device)
    out = Path(args.out) / f"{args.method}.safetensors"
    policy = "train_test_split.csv" if ds.splits else f"first {round(args.train_fraction * 100)}% of each take"
    model = train_generator(train, held, tokenizers, tc, out, config=config, meta={"data": policy, "takes": ds.names})
    if args.ship and (not torch.distributed.is_initialized() or torch.distributed.get_rank() == 0):
        path = model.save(Path(args.ship) / f"{args.method}.safetensors", half=True,
                          meta={"data": policy, "steps": tc.steps, "preset": tc.preset, "train": tc.__dict__})
        print(f"shipped {path} ({path.stat().st_size / 1e6:.1f} MB)")
    return 0


def preset_with(preset: str, overrides: list[str]):
    """A named GeneratorConfig preset with FIELD=VALUE overrides (values parsed as the field's type)."""
    import dataclasses

    from ..cli import UserError
    from .config import PRESETS

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


def run_generate(args: argparse.Namespace) -> int:
    import time

    from ..audio import load_audio
    from ..pipeline import GesturePipeline

    t0 = time.perf_counter()
    audio = load_audio(args.audio)
    words = None
    if args.textgrid:
        from ..align.textgrid import read_words

        words = read_words(args.textgrid)
    pipe = GesturePipeline.from_pretrained(args.checkpoints, methods=[args.method])
    steps = args.steps or {**DEFAULT_STEPS, **AUTHORS_STEPS}[args.method]
    res = pipe.generate(audio, 16000, words=words, text=args.text, steps=steps, cfg=args.cfg, seed=args.seed,
                        method=args.method)
    path = res.motion.save(args.out)
    for w in res.warnings:
        print(f"warning: {w}")
    stages = ", ".join(f"{k} {v:.2f}s" for k, v in res.timings.items())
    print(f"{path}: {res.motion.num_frames} frames ({res.motion.duration:.1f} s) with {args.method}, {steps} steps, "
          f"CFG {args.cfg}, seed {args.seed}; {res.text_mode}")
    print(f"timings: {stages}; real-time factor {res.real_time_factor:.1f}x; total {time.perf_counter() - t0:.1f}s")
    return 0
