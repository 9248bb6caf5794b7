"""`gesturelsm export`: a motion npz -> BVH, animated GLB, OpenPose keypoints, ARKit face blendshapes (a Live Link
Face CSV), or a clean BEAT2 npz.

    gesturelsm export take.npz --bvh take.bvh --glb take.glb --keypoints take_keypoints/
    gesturelsm export take.npz --keypoints take_keypoints.json --size 768x512   # one file, all frames
    gesturelsm export take.npz --npz clean.npz                                    # BEAT2 / Blender add-on npz
    gesturelsm export take.npz --arkit take_face.csv                              # Unreal / Unity face rigs
    gesturelsm export take.npz --rig avatar.vrm --glb avatar_take.vrm --bvh avatar_take.bvh   # your character
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from typing import TYPE_CHECKING

from ..errors import UserError

if TYPE_CHECKING:
    from ..motion.sequence import MotionSequence

NAME = "export"
HELP = "export a motion to BVH / GLB / 2D keypoints / ARKit face CSV / BEAT2 npz"


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(NAME, help=HELP,
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("motion", help="BEAT2-layout .npz motion file")
    p.add_argument("--bvh", help="write a BVH (SMPL-X skeleton, 30 fps)")
    p.add_argument("--glb", help="write an animated, skinned GLB (glTF 2.0)")
    p.add_argument("--keypoints", help="write OpenPose 2D keypoints: a folder (one JSON per frame) or FILE.json")
    p.add_argument("--npz", help="write a checked BEAT2-layout npz")
    p.add_argument("--arkit", help="write the face as ARKit's 52 blendshapes + head / eye rotations per frame, in "
                   "Live Link Face's CSV layout (FILE.csv; Unreal's Live Link Face importer, Unity, Blender)")
    p.add_argument("--model", help="SMPL-X npz (default: $GESTURELSM_SMPLX_MODEL or the built-in mannequin)")
    p.add_argument("--units", choices=["cm", "m"], default="cm", help="BVH units (default cm)")
    p.add_argument("--names", choices=["animator", "smplx"], default="animator",
                   help="joint names: animator (Hips, LeftArm, ...) or smplx (pelvis, left_shoulder, ...)")
    p.add_argument("--size", default="512x512", help="keypoint image size, as the render's (default 512x512)")
    p.add_argument("--rig", help="your character (.vrm / .glb / .gltf / .bvh): --glb writes its own file animated "
                   "(a VRM stays a VRM), --bvh its skeleton")
    p.add_argument("--bone-map", help="with --rig: bone names as 'mixamo', 'smplx' or a JSON file {SMPL-X joint: "
                   "bone} (default: the VRM humanoid map, else the preset that fits)")
    p.add_argument("--grounding", choices=("on", "off"), default="on",
                   help="with --rig: the character's feet planted on its own legs (the same leg IK on its skeleton; "
                   "off: its legs as retargeted)")
    p.add_argument("--style", default="default", help="keypoint framing as `gesturelsm render --style`, e.g. "
                   "upper (default: default)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..body.model import resolve_body
    from ..export import export_arkit, export_bvh, export_glb, export_keypoints, export_npz
    from ..motion.sequence import MotionSequence
    from ..render.style import STYLES, parse_size

    arkit = getattr(args, "arkit", None)
    if not any((args.bvh, args.glb, args.keypoints, args.npz, arkit)):
        raise UserError("nothing to export: give at least one of --bvh, --glb, --keypoints, --arkit, --npz")
    if arkit and Path(arkit).suffix.lower() != ".csv":
        raise UserError(f"--arkit {arkit}: use a .csv file name (the Live Link Face CSV)")
    if args.keypoints and args.style not in STYLES:
        raise UserError(f"--style {args.style!r}: choose from {', '.join(STYLES)}")
    size = parse_size(args.size) if args.keypoints else None
    if not Path(args.motion).exists():
        raise UserError(f"motion file not found: {args.motion}")
    _check_outputs(args)                                   # every output can be written, before any work
    seq = MotionSequence.load(args.motion)                 # the one guarded reader: one line for a bad file
    if getattr(args, "rig", None):
        return _run_rig(args, seq)
    body = None
    if args.bvh or args.glb or args.keypoints or arkit:
        body = resolve_body(args.model)
    jobs = [(flag, write) for flag, write in (
        ("--npz", args.npz and (lambda: export_npz(seq, args.npz))),
        ("--bvh", args.bvh and (lambda: export_bvh(seq, args.bvh, body=body, units=args.units, names=args.names))),
        ("--glb", args.glb and (lambda: export_glb(seq, args.glb, body=body, names=args.names))),
        ("--keypoints", args.keypoints and (lambda: export_keypoints(seq, args.keypoints, size=size, body=body,
                                                                     style=STYLES[args.style]))),
        ("--arkit", arkit and (lambda: export_arkit(seq, arkit, body=body)))) if write]
    t0 = time.perf_counter()
    for i, (flag, write) in enumerate(jobs):
        if len(jobs) > 1:           # several formats of a long take take a while: say which one is being written
            print(f"[{i + 1}/{len(jobs)}] {flag[2:]}: writing {seq.num_frames} frames ...", flush=True)
        print(f"wrote {write()}" + (f" ({time.perf_counter() - t0:.1f} s)" if len(jobs) > 1 else ""), flush=True)
    return 0


def _check_outputs(args: argparse.Namespace) -> None:
    """Each output path can be written (a file made and removed in its nearest existing folder), all problems at
    once, before the motion is read or a body model loaded."""
    problems = []
    for flag in ("npz", "bvh", "glb", "keypoints", "arkit"):
        value = getattr(args, flag, None)
        if not value:
            continue
        path = Path(value)
        folder = path if flag == "keypoints" and path.suffix.lower() != ".json" else path.parent
        if path.is_dir() and folder is not path:
            problems.append(f"--{flag} {path} is a folder; give a file name")
            continue
        while not folder.exists() and folder != folder.parent:
            folder = folder.parent
        if not folder.is_dir():
            problems.append(f"--{flag} {path}: cannot write there: {folder} is a file, not a folder")
            continue
        try:
            with tempfile.NamedTemporaryFile(dir=folder, prefix=".gesturelsm-probe-"):
                pass
        except OSError as exc:
            problems.append(f"--{flag} {path}: cannot write in {folder} ({exc.strerror or exc})")
    if problems:
        raise UserError("; ".join(problems))


def _run_rig(args: argparse.Namespace, seq: MotionSequence) -> int:
    """--rig: the motion on the user's character, as its own animated file and / or its skeleton's BVH."""
    from ..export.rig import export_rig_bvh, export_rig_glb
    from ..retarget import load_character, retarget_motion

    if args.keypoints or args.npz or getattr(args, "arkit", None) or not (args.glb or args.bvh):
        raise UserError("with --rig, give --glb OUT.glb (or .vrm) and / or --bvh OUT.bvh (export --keypoints, "
                        "--arkit and --npz without --rig)")
    character = load_character(args.rig, args.bone_map)
    if args.glb and character.document is None:
        raise UserError(f"--rig {character.name}: a BVH skeleton has no mesh to animate; use --bvh only")
    result = retarget_motion(seq, character, args.model, grounding=getattr(args, "grounding", "on") == "on")
    if result.note:
        print(result.note)
    if args.glb:
        print(f"wrote {export_rig_glb(seq, character, args.glb, result=result)}")
    if args.bvh:
        print(f"wrote {export_rig_bvh(seq, character, args.bvh, result=result)}")
    return 0
