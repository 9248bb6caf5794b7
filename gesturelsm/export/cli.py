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
from pathlib import Path

from ..body.model import resolve_body
from ..errors import UserError
from ..motion.sequence import MotionSequence
from ..render.style import STYLES, parse_size
from . import export_arkit, export_bvh, export_glb, export_keypoints, export_npz


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("export", help="export a motion to BVH / GLB / 2D keypoints / ARKit face CSV / BEAT2 npz",
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
    arkit = getattr(args, "arkit", None)
    if not any((args.bvh, args.glb, args.keypoints, args.npz, arkit)):
        raise UserError("nothing to export: give at least one of --bvh, --glb, --keypoints, --arkit, --npz")
    if arkit and Path(arkit).suffix.lower() != ".csv":
        raise UserError(f"--arkit {arkit}: use a .csv file name (the Live Link Face CSV)")
    if not Path(args.motion).exists():
        raise UserError(f"motion file not found: {args.motion}")
    seq = MotionSequence.load(args.motion)
    if getattr(args, "rig", None):
        return _run_rig(args, seq)
    body = None
    if args.bvh or args.glb or args.keypoints or arkit:
        body = resolve_body(args.model)
    done = []
    if args.npz:
        done.append(export_npz(seq, args.npz))
    if args.bvh:
        done.append(export_bvh(seq, args.bvh, body=body, units=args.units, names=args.names))
    if args.glb:
        done.append(export_glb(seq, args.glb, body=body, names=args.names))
    if args.keypoints:
        if args.style not in STYLES:
            raise UserError(f"--style {args.style!r}: choose from {', '.join(STYLES)}")
        done.append(export_keypoints(seq, args.keypoints, size=parse_size(args.size), body=body,
                                     style=STYLES[args.style]))
    if arkit:
        done.append(export_arkit(seq, arkit, body=body))
    for p in done:
        print(f"wrote {p}")
    return 0


def _run_rig(args: argparse.Namespace, seq: MotionSequence) -> int:
    """--rig: the motion on the user's character, as its own animated file and / or its skeleton's BVH."""
    from ..retarget import load_character, retarget_motion
    from .rig import export_rig_bvh, export_rig_glb

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
