#!/usr/bin/env python
"""Render a body (default: the built-in mannequin) posed with one frame of the real BEAT2 take.

    python scripts/mannequin_preview.py --frame 300 --out /tmp/pose.png [--model PATH]
        [--views front,threequarter,left_hand] [--rest] [--size 512]

Each view is one tile of the output strip: front, threequarter, side, back (whole body), left_hand,
right_hand, face, face_side, upper_{front,threequarter,side,back}, hips_{front,threequarter,side,back}.
`--rest` adds the same views of the rest pose (T-pose) as a second row. Offscreen with pyrender (OSMesa).
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("PYOPENGL_PLATFORM", "osmesa")
os.environ.setdefault("PYGLET_HEADLESS", "true")

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
TAKE = REPO.parent / "shared" / "data" / "beat2" / "smplxflame_30" / "2_scott_0_1_1.npz"


def look_at(eye: np.ndarray, target: np.ndarray, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    z = eye - target
    z = z / np.linalg.norm(z)
    x = np.cross(up, z)
    x = x / np.linalg.norm(x)
    M = np.eye(4)
    M[:3, 0], M[:3, 1], M[:3, 2], M[:3, 3] = x, np.cross(z, x), z, eye
    return M


def camera_for(view: str, verts: np.ndarray, joints: np.ndarray, yfov: float) -> np.ndarray:
    lo, hi = verts.min(0), verts.max(0)
    if view in ("left_hand", "right_hand"):
        w = joints[20 if view == "left_hand" else 21]
        tips = joints[25:40] if view == "left_hand" else joints[40:55]
        target = (w + tips.mean(0)) / 2
        return look_at(target + np.array([0.0, 0.22, 0.24]), target)
    if view in ("face", "face_side"):
        h = joints[15] + np.array([0.0, 0.07, 0.03])
        return look_at(h + (np.array([0.10, 0.0, 0.62]) if view == "face" else np.array([0.62, 0.0, 0.05])), h)
    if view.startswith(("upper_", "hips_")):
        c = joints[9] + np.array([0.0, 0.05, 0.0]) if view.startswith("upper_") else joints[0]
        a = np.deg2rad({"front": 0.0, "threequarter": 35.0, "side": 90.0, "back": 180.0}[view.split("_")[1]])
        return look_at(c + 1.9 * np.array([np.sin(a), 0.05, np.cos(a)]), c)
    target = (lo + hi) / 2
    dist = 0.56 * (hi[1] - lo[1]) / np.tan(yfov / 2) + 0.25
    ang = {"front": 0.0, "threequarter": 35.0, "side": 90.0, "back": 180.0}[view]
    a = np.deg2rad(ang)
    return look_at(target + dist * np.array([np.sin(a), 0.0, np.cos(a)]), target)


def render_views(verts: np.ndarray, faces: np.ndarray, joints: np.ndarray, views: list[str],
                 size: int) -> list[np.ndarray]:
    import pyrender
    import trimesh

    yfov = np.deg2rad(30.0)
    scene = pyrender.Scene(bg_color=[1.0, 1.0, 1.0, 1.0], ambient_light=[0.15, 0.15, 0.15])
    mat = pyrender.MetallicRoughnessMaterial(baseColorFactor=[0.62, 0.58, 0.55, 1.0], metallicFactor=0.0,
                                            roughnessFactor=0.65)
    scene.add(pyrender.Mesh.from_trimesh(trimesh.Trimesh(verts, faces, process=False), material=mat, smooth=True))
    floor = trimesh.creation.box(extents=[3.0, 0.01, 3.0])
    floor.apply_translation([verts[:, 0].mean(), -0.005, verts[:, 2].mean()])
    fmat = pyrender.MetallicRoughnessMaterial(baseColorFactor=[0.55, 0.6, 0.68, 1.0], metallicFactor=0.0)
    scene.add(pyrender.Mesh.from_trimesh(floor, material=fmat))
    for d, k in (((0.5, 0.9, 0.8), 2.2), ((-0.8, 0.2, 0.5), 0.8), ((0.0, 0.6, -1.0), 0.9)):
        scene.add(pyrender.DirectionalLight(intensity=k), pose=look_at(np.array(d), np.zeros(3)))
    cam = scene.add(pyrender.PerspectiveCamera(yfov=yfov, znear=0.02), pose=np.eye(4))
    r = pyrender.OffscreenRenderer(size, size)
    out = []
    for v in views:
        scene.set_pose(cam, camera_for(v, verts, joints, yfov))
        out.append(r.render(scene)[0])
    r.delete()
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frame", type=int, default=0)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--model", default=None, help="SMPL-X npz (default: $GESTURELSM_SMPLX_MODEL or the mannequin)")
    ap.add_argument("--motion", type=Path, default=TAKE, help="BEAT2 npz (default: the real take in ../shared)")
    ap.add_argument("--views", default="front,threequarter")
    ap.add_argument("--rest", action="store_true", help="add a row with the rest pose")
    ap.add_argument("--size", type=int, default=512)
    args = ap.parse_args(argv)

    import imageio.v2 as imageio

    from gesturelsm.body import load_body_model
    from gesturelsm.motion import MotionSequence

    from gesturelsm.body import BodyModelError
    from gesturelsm.motion.sequence import MotionFileError

    try:
        body = load_body_model(args.model)
        seq = MotionSequence.load(args.motion)
    except (BodyModelError, MotionFileError) as exc:
        print(f"mannequin_preview: error: {exc}", file=sys.stderr)
        return 2
    if not 0 <= args.frame < len(seq):
        ap.error(f"--frame must be in 0..{len(seq) - 1}")
    seq = seq.slice(args.frame, args.frame + 1)
    views = args.views.split(",")
    rows = []
    poses = [seq.poses]
    if args.rest:
        poses.append(np.zeros_like(seq.poses))
    for p in poses:
        out = body.forward(p, seq.trans, seq.expressions, seq.betas)
        rows.append(np.concatenate(render_views(out.vertices[0], body.faces, out.joints[0], views, args.size), 1))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    imageio.imwrite(args.out, np.concatenate(rows, 0))
    print(f"wrote {args.out} ({body.path.name}, frame {args.frame})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
