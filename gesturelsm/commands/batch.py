"""`gesturelsm batch`: blinded videos of every speech x method for a user study, with a key kept apart, and the
study's one design (pairwise or 1-5 ratings, with attention checks) with a link per rater for
`gesturelsm study serve`. Rerunning skips finished videos; a rerun with other settings than the study's is refused.

    gesturelsm batch --audio-dir speech/ --methods gesturelsm rectified_flow ddim --out study/ --raters 12
    (a transcript per speech file is used when speech/NAME.txt or speech/NAME.TextGrid exists)
    gesturelsm batch ... --cluster local        (or auto, ray://HOST:PORT: each video a task, docs/CLUSTER.md)

Each video's motion is kept beside the key (key/motion/v_XXXXXXXXXX.npz, BEAT2 layout).
"""
from __future__ import annotations

import argparse
import contextlib

from ..cluster import add_cluster_argument, check_reachable, connect
from ..errors import GestureError, UserError
from ..settings.arguments import (add_language_flag, add_methods_flag, add_post_flags, add_settings_flags,
                                  cli_settings, input_file, input_folder, output_folder, refuse)
from ..settings.values import from_text, real_number, whole_number
from ..study.design import MODES

MAX_RATERS = 10_000
NAME = "batch"
HELP = "render blinded user-study videos, their key and the study's design and links (resumable)"


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    from ..backends import GROUND_TRUTH, SPECS, ours_default

    p = subparsers.add_parser(NAME, help=HELP, description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--audio-dir", required=True, help="folder of speech files (wav, flac, mp3, ...)")
    add_methods_flag(p, default=ours_default(),
                     help=f"{', '.join(SPECS)}, {GROUND_TRUTH} (needs --beat2) (default: {' '.join(ours_default())})")
    p.add_argument("--out", required=True, help="output folder (videos/, key/, study.json)")
    p.add_argument("--raters", type=from_text, default=10,
                   help="number of rater links (a rerun with more adds links; default: 10)")
    add_settings_flags(p, steps="two")
    add_language_flag(p)
    p.add_argument("--size", type=from_text, default=512, help="video size in pixels (square; default: 512)")
    p.add_argument("--checkpoints", help="folder with tokenizer/ and generator/ (default: shipped assets/)")
    p.add_argument("--model", help="SMPL-X .npz body model (default: the built-in mannequin)")
    p.add_argument("--beat2", help="BEAT2-layout folder, for ground_truth videos of its takes")
    add_post_flags(p)
    p.add_argument("--design", default="pairwise", choices=MODES,
                   help="the study's design: pairwise preference between methods on the same speech; each "
                   "video rated 1-5 on realness, synchrony and smoothness; or appropriateness: a method's motion for "
                   "the speech heard against its motion for another speech, both with the speech heard (GENEA's "
                   "mismatching protocol) (default: pairwise)")
    p.add_argument("--attention", type=from_text, default=0.15,
                   help="attention checks per real trial (mismatched speech and repeated trials)")
    p.add_argument("--rig", help="your character (.vrm / .glb): the videos show its own mesh instead of the "
                   "mannequin, and each video also gets its motion on the character (same blinded name, .vrm / .glb)")
    p.add_argument("--segments", help="CSV of evaluation segments (file_name,start_seconds,end_seconds,"
                   "duration_seconds, the GENEA Leaderboard's layout): each video is cut to the listed segments and "
                   "the study is over them (docs/STUDY.md)")
    add_cluster_argument(p, "each video (generate, render, exports)")
    p.set_defaults(func=run)


def check_arguments(args: argparse.Namespace):
    """(settings, raters, size, attention), every problem at once before any work (InputError)."""
    from ..backends import GROUND_TRUTH
    from ..study.batch import find_audio

    p: list[str] = []
    settings = cli_settings(args, args.methods, p)
    attention = real_number(args.attention, "--attention", 0.0, 1.0, p)
    raters = whole_number(args.raters, "--raters", 1, MAX_RATERS, p)
    size = whole_number(args.size, "--size", 128, 1024, p)
    if size is not None and size % 16:
        p.append(f"--size must be a multiple of 16 from 128 to 1024 (got {size}).")
    if input_folder(args.audio_dir, "--audio-dir", p) is not None:
        try:
            find_audio(args.audio_dir)
        except GestureError as exc:
            p.append(f"--audio-dir: {exc}")
    if args.design == "pairwise" and len(set(args.methods or ())) < 2:      # before Ray starts (docs/CLUSTER.md)
        p.append(f"a pairwise study needs at least two methods rendered for the same speech (got --methods "
                 f"{' '.join(args.methods or ()) or 'none'}); add one, or use --design {MODES[-1]}")
    output_folder(args.out, "--out", p)
    if args.rig:
        input_file(args.rig, "--rig", p)
    if args.segments:
        input_file(args.segments, "--segments", p)
    if args.beat2:
        input_folder(args.beat2, "--beat2", p)
    elif GROUND_TRUTH in args.methods:
        p.append("ground_truth needs --beat2 (the BEAT2 folder the speech comes from)")
    refuse(p)
    return settings, raters, size, attention


def run(args: argparse.Namespace) -> int:
    from ..backends import checkpoint_sources
    from ..body import load_body_model
    from ..body.model import resolve_model_path
    from ..pipeline import GesturePipeline
    from ..study.batch import make_study
    from ..study.design import Design

    settings, raters, size, attention = check_arguments(args)
    check_reachable(args.cluster)                # before the character and the models load
    rig = _character(args.rig)
    pipe = GesturePipeline.from_pretrained(checkpoints=checkpoint_sources(args.checkpoints),
                                           methods=settings.generators or None)
    body = load_body_model(str(resolve_model_path(args.model)))
    with connect(args.cluster) if args.cluster else contextlib.nullcontext() as conn:
        make_study(pipe, args.audio_dir, args.out, settings, raters=raters, size=size, body=body, beat2=args.beat2,
                   design=Design(args.design, attention, settings.seed), rig=rig, connection=conn,
                   checkpoints=checkpoint_sources(args.checkpoints), segments=args.segments)
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
