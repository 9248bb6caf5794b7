"""`gesturelsm batch`: blinded videos of every speech x method for a user study, with a key kept apart, and the
study's one design (pairwise or 1-5 ratings, with attention checks) with a link per rater for
`gesturelsm study serve`. Rerunning skips finished videos; a rerun with other settings than the study's is refused.

    gesturelsm batch --audio-dir speech/ --methods gesturelsm rectified_flow ddim --out study/ --raters 12
    (a transcript per speech file is used when speech/NAME.txt or speech/NAME.TextGrid exists)
"""
from __future__ import annotations

import argparse

from ..body import load_body_model
from ..body.model import resolve_model_path
from ..errors import UserError
from ..grounding.cli import add_grounding_flag, grounding_on
from ..backends import FACTS, checkpoint_sources
from ..presentation import steps_from_flags
from ..motion.postprocess import DEFAULT_SMOOTHING, SMOOTHING_WINDOWS
from ..pipeline import GROUND_TRUTH, GesturePipeline
from .batch import make_study
from .design import MODES, Design


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("batch", help="render blinded user-study videos, their key and the study's design and "
                              "links (resumable)", description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--audio-dir", required=True, help="folder of speech files (wav, flac, mp3, ...)")
    p.add_argument("--methods", nargs="+", default=["gesturelsm", "rectified_flow", "ddim"],
                   help="gesturelsm, rectified_flow, ddim, ground_truth (needs --beat2)")
    p.add_argument("--out", required=True, help="output folder (videos/, key/, study.json)")
    p.add_argument("--raters", type=int, default=10, help="number of rater links (a rerun with more adds links)")
    p.add_argument("--steps", type=int, default=8, help="sampling steps for GestureLSM and rectified flow")
    p.add_argument("--ddim-steps", type=int, default=20, help="DDIM steps")
    p.add_argument("--cfg", type=float, default=2.0, help="classifier-free guidance scale")
    p.add_argument("--seed", type=int, default=0, help="generation seed; also seeds the presentation orders")
    p.add_argument("--size", type=int, default=512, help="video size in pixels (square)")
    p.add_argument("--checkpoints", help="folder with tokenizer/ and generator/ (default: shipped assets/)")
    p.add_argument("--model", help="SMPL-X .npz body model (default: the built-in mannequin)")
    p.add_argument("--beat2", help="BEAT2-layout folder, for ground_truth videos of its takes")
    p.add_argument("--stand-in-place", action="store_true", help="remove horizontal root movement")
    p.add_argument("--smoothing", default=DEFAULT_SMOOTHING, choices=list(SMOOTHING_WINDOWS),
                   help=f"post-processing of every method and ground truth (default {DEFAULT_SMOOTHING})")
    add_grounding_flag(p)
    p.add_argument("--design", default="pairwise", choices=MODES,
                   help="the study's design: pairwise preference between methods on the same speech, or each "
                   "video rated 1-5 on realness, synchrony and smoothness")
    p.add_argument("--attention", type=float, default=0.15,
                   help="attention checks per real trial (mismatched speech and repeated trials; default 0.15)")
    p.add_argument("--rig", help="your character (.vrm / .glb): the videos show its own mesh instead of the "
                   "mannequin, and each video also gets its motion on the character (same blinded name, .vrm / .glb)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if not 0 <= args.attention <= 1:
        raise UserError("--attention must be a fraction from 0 to 1")
    if args.size % 16 or not 128 <= args.size <= 1024:
        raise UserError("--size must be a multiple of 16 from 128 to 1024")
    gens = [m for m in args.methods if m != GROUND_TRUTH]
    rig = _character(args.rig)
    pipe = GesturePipeline.from_pretrained(checkpoints=checkpoint_sources(args.checkpoints), methods=gens or None)
    body = load_body_model(str(resolve_model_path(args.model)))
    make_study(pipe, args.audio_dir, args.methods, args.out, raters=args.raters,
               steps=steps_from_flags(args.steps, args.ddim_steps, FACTS), cfg=args.cfg, seed=args.seed, size=args.size,
               body=body, beat2=args.beat2, stand_in_place=args.stand_in_place, smoothing=args.smoothing,
               design=Design(args.design, args.attention, args.seed), rig=rig, grounding=grounding_on(args))
    return 0


def _character(path: str | None):
    """--rig, loaded before any work so a bad file stops the batch at once."""
    if not path:
        return None
    from ..retarget import check_usable, load_character

    rig = load_character(path)
    if rig.document is None:
        raise UserError(f"--rig {rig.name}: a BVH skeleton has no mesh; give a .vrm, .glb or .gltf")
    check_usable(rig)                       # its rest pose retargets and its meshes can be drawn
    return rig
