"""`gesturelsm render`: motion npz file(s) + speech -> mp4 (side by side when several).

    gesturelsm render out.npz --audio speech.wav --out out.mp4
    gesturelsm render lsm.npz rf.npz ddim.npz gt.npz --audio speech.wav --out cmp.mp4 \\
        --labels "GestureLSM 8 steps" "rectified flow 8" "DDIM 20" "ground truth" --gen-times 0.4 0.4 2.1 -
    gesturelsm render out.npz --audio speech.wav --out frame.png --frame 120     # one still frame
    gesturelsm render out.npz --audio speech.wav --out avatar.mp4 --rig avatar.vrm  # on your character's mesh
"""
from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

from ..errors import UserError
from ..progress import Line

NAME = "render"
HELP = "render motion(s) with the speech to an mp4 (offscreen, CPU)"


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(NAME, help=HELP,
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("motions", nargs="+", help="BEAT2-layout .npz motion file(s); several are shown side by side")
    p.add_argument("--audio", help="speech file (wav, flac, mp3, ...) played with the video; omit for silence")
    p.add_argument("--out", required=True, help="output .mp4 (or .png with --frame)")
    p.add_argument("--labels", nargs="+", help="one label per motion (default: file names when several)")
    p.add_argument("--no-labels", action="store_true", help="draw no labels")
    p.add_argument("--gen-times", nargs="+", metavar="SECONDS",
                   help="generation time per motion, shown under its label ('-' for none)")
    p.add_argument("--size", default="512x512", help="one body's tile, WIDTHxHEIGHT (default 512x512)")
    p.add_argument("--style", default="default", help="default | plain | dark | upper (hips up, larger face) "
                   "(default: default)")
    p.add_argument("--background", help="background colour, e.g. '#ffffff' (default: the --style's own)")
    p.add_argument("--floor", choices=["grid", "plain", "none"], help="floor look (default grid)")
    p.add_argument("--supersample", type=int, choices=[1, 2, 3], help="antialiasing: render k x larger and "
                   "average down (2 = smoother edges, ~3x slower) (default: 1, no antialiasing)")
    p.add_argument("--model", help="SMPL-X npz (default: $GESTURELSM_SMPLX_MODEL or the built-in mannequin)")
    p.add_argument("--rig", help="your character (.vrm / .glb / .gltf): its own mesh is drawn, posed by the motion "
                   "(retargeted), instead of the mannequin; a .bvh skeleton has no mesh and keeps the mannequin")
    p.add_argument("--bone-map", help="with --rig: bone names as 'mixamo', 'smplx' or a JSON file {SMPL-X joint: "
                   "bone name} (a VRM brings its own)")
    p.add_argument("--grounding", choices=("on", "off"), default="on",
                   help="with --rig: the character's feet planted on its own legs (off: its legs as retargeted)")
    p.add_argument("--frame", type=int, help="write only this frame as a PNG")
    p.add_argument("--crf", type=int, default=20, help="x264 quality, lower = better (default 20)")
    p.add_argument("--quiet", action="store_true",
                   help="no progress (one line redrawn on a terminal, a line per tenth of the frames otherwise)")
    p.add_argument("--progress-json", action="store_true",
                   help='progress as JSON lines on stdout ({"fraction": 0.5, "message": "..."}) for programs')
    p.set_defaults(func=run)


def _gen_times(values: list[str] | None) -> list[float | None] | None:
    if values is None:
        return None
    out: list[float | None] = []
    for v in values:
        if v in ("-", "none", ""):
            out.append(None)
            continue
        try:
            out.append(float(v.rstrip("s")))
        except ValueError:
            raise UserError(f"--gen-times: {v!r} is not a number of seconds (use '-' for none)") from None
    return out


def _style(args: argparse.Namespace):
    """--style with --size, --background, --floor and --supersample over it."""
    from dataclasses import replace

    from ..render import STYLES, parse_size

    if args.style not in STYLES:
        raise UserError(f"--style {args.style!r}: choose from {', '.join(STYLES)}")
    style = replace(STYLES[args.style], size=parse_size(args.size))
    if args.background:
        style = replace(style, background=args.background)
    if args.floor:
        style = replace(style, floor=args.floor)
    if args.supersample:
        style = replace(style, supersample=args.supersample)
    return style


def _json_lines(fraction: float, message: str) -> None:
    """--progress-json: one JSON object a step on stdout (render/background.py reads them)."""
    print(json.dumps({"fraction": round(fraction, 4), "message": message}), flush=True)


def run(args: argparse.Namespace) -> int:
    from ..render import RenderError, render_frames, render_video
    from ..render.frames import RenderWarning

    style = _style(args)
    # default labels: file names when several motions are compared; none for a single one (its framing
    # then equals the keypoint export's camera)
    labels = None if args.no_labels else (args.labels or ([Path(m).stem for m in args.motions]
                                                          if len(args.motions) > 1 else None))
    if labels is not None and len(labels) != len(args.motions):
        raise UserError(f"{len(labels)} labels for {len(args.motions)} motions: give one --labels entry per motion")
    gen = _gen_times(args.gen_times)
    if gen is not None and len(gen) != len(args.motions):
        raise UserError(f"{len(gen)} --gen-times for {len(args.motions)} motions: give one per motion ('-' for none)")
    for m in args.motions:
        if not Path(m).exists():
            raise UserError(f"motion file not found: {m}")
    character = None
    if args.rig:
        from ..retarget import load_character

        character = load_character(args.rig, args.bone_map)          # CharacterError: one line, before any work
    elif args.bone_map:
        raise UserError("--bone-map goes with --rig CHARACTER")
    if args.audio is None and args.frame is None:
        print("note: no --audio given, the video will be silent", file=sys.stderr)
    out = Path(args.out)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", RenderWarning)
        try:
            if args.frame is not None:
                import imageio.v3 as iio

                if out.suffix.lower() not in (".png", ".jpg", ".jpeg"):
                    raise UserError("--frame writes an image: give --out NAME.png")
                frame = render_frames(args.motions, [args.frame], body=args.model, style=style, labels=labels,
                                      gen_seconds=gen, character=character, grounding=args.grounding == "on")[0]
                out.parent.mkdir(parents=True, exist_ok=True)
                iio.imwrite(out, frame)
            else:
                # the frames on stderr (progress.Line: one line redrawn on a terminal, a line per tenth in a log);
                # --progress-json: JSON lines on stdout for programs; --quiet: nothing
                progress = _json_lines if args.progress_json else None if args.quiet else Line()
                render_video(args.motions, args.audio, out, labels=labels, body=args.model, style=style,
                             gen_seconds=gen, progress=progress, crf=args.crf, character=character,
                             grounding=args.grounding == "on")
        except RenderError as exc:
            raise UserError(str(exc)) from None
        for w in caught:
            if issubclass(w.category, RenderWarning):
                print(f"note: {w.message}", file=sys.stderr)
    print(f"wrote {out}")
    return 0
