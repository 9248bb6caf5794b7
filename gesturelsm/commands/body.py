"""`gesturelsm body`: build the built-in mannequin file, or check that a body model file loads.

    gesturelsm body build [--out PATH]      rebuild assets/body/SMPLX_MANNEQUIN.npz (or PATH)
    gesturelsm body check [--model PATH]    load a body (default: $GESTURELSM_SMPLX_MODEL or the mannequin)
"""
from __future__ import annotations

import argparse
from pathlib import Path

NAME = "body"
HELP = "build or check the SMPL-X body model"


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(NAME, help=HELP,
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="body_command", metavar="ACTION", required=True)
    b = sub.add_parser("build", help="rebuild the built-in mannequin npz",
                       description="Rebuild the built-in mannequin body model (an SMPL-X-layout npz made from "
                                   "primitives, no licensed data) and write it.")
    b.add_argument("--out", type=Path, default=None, help="output file (default: assets/body/SMPLX_MANNEQUIN.npz)")
    b.set_defaults(func=run_build)
    c = sub.add_parser("check", help="load a body model file and print what it contains",
                       description="Load a body model file as every command would and print what it contains "
                                   "(vertices, faces, joints, height, pelvis height in the rest pose).")
    c.add_argument("--model", default=None, help="SMPL-X npz or a folder holding SMPLX_NEUTRAL_2020.npz")
    c.set_defaults(func=run_check)


def run_build(args: argparse.Namespace) -> int:
    import numpy as np

    from ..body.mannequin import DEFAULT_PATH, write_mannequin

    path = write_mannequin(args.out or DEFAULT_PATH)
    with np.load(path) as d:
        V, F = len(d["v_template"]), len(d["f"])
    print(f"wrote {path} ({V} vertices, {F} faces, {path.stat().st_size / 1e6:.2f} MB)")
    return 0


def run_check(args: argparse.Namespace) -> int:
    from ..body.model import load_body_model

    body = load_body_model(args.model)   # BodyModelError (a ValueError) -> one clear line, exit 2
    J = body.rest_joints()
    print(f"model:     {body.path}")
    print(f"vertices:  {body.num_vertices}")
    print(f"faces:     {len(body.faces)}")
    print(f"joints:    {len(J)} (+ smplx extra joints from vertex ids)")
    print(f"height:    {body.height():.3f} m (rest pose, zero betas)")
    print(f"pelvis:    y = {J[0, 1]:+.3f} m in the rest pose")
    return 0
