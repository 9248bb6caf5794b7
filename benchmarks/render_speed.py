"""Rendering speed on this machine: frames per second at 512 x 512 for one body and for three side by side
(the built-in 7.5k-vertex mannequin and a 10,475-vertex SMPL-X-sized body), and seconds to render + encode
10 s and 60 s clips with speech into a browser-playable mp4.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/render_speed.py [--frames 90] [--size 512] [--quick]
        [--rig ../shared/assets/characters/cryptovoxels.vrm]

fps = 1 / median time per frame over `--frames` consecutive frames (posing, normals, upload, render
passes, read-back, labels; the first frame, with camera fitting and shader compilation, is left out).
cpu ms/frame = process CPU time (all threads, llvmpipe's included) per frame: unlike fps it barely
changes when other jobs share the cores; "fps if idle" = cores / CPU time assumes perfect parallelism, so
treat it as an upper bound. Clip rows are wall time of `render_video` (setup, rendering, x264 + AAC
encoding in a parallel ffmpeg process) for one mannequin body. One run; the machine may be shared.
Motion: the real BEAT2 take 2_scott_0_1_1 (../shared) when present, else smooth synthetic motion.
The 10k body is the mannequin with its largest faces split (trimesh.remesh.subdivide) until it has
10,475 vertices (SMPL-X's count; ~21k faces) and small non-zero pose correctives, so its geometry,
fill and posing cost are SMPL-X-like (the random-face synthetic model of tests/body would not be).
With `--rig CHARACTER` the same rows and clips are measured for the character's own mesh (retargeting, numpy
skinning and its materials; `gesturelsm render --rig`), beside the mannequin's in the same run.
"""
from __future__ import annotations

from _harness import BEAT2

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
SHARED = BEAT2
TAKE = "2_scott_0_1_1"
SMPLX_V = 10475


def build_10k_body(path: Path) -> Path:
    """An SMPL-X-sized body file (10,475 vertices) from the mannequin: largest faces subdivided."""
    import trimesh.remesh

    from gesturelsm.body.mannequin import DEFAULT_PATH

    with np.load(DEFAULT_PATH) as d:
        a = {k: d[k] for k in d.files}
    v, f = a["v_template"].astype(np.float64), a["f"].astype(np.int64)
    V0 = len(v)
    attrs = {"w": a["weights"], "s": a["shapedirs"].reshape(V0, -1), "j": a["J_regressor"].T}
    area = np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    order = np.argsort(-area)
    lo, hi = 0, len(f)
    while lo < hi:                                        # most faces whose split stays <= SMPLX_V vertices
        mid = (lo + hi + 1) // 2
        nv = len(trimesh.remesh.subdivide(v, f, face_index=order[:mid])[0])
        lo, hi = (mid, hi) if nv <= SMPLX_V else (lo, mid - 1)
    nv_, nf_, at = trimesh.remesh.subdivide(v, f, face_index=order[:lo], vertex_attributes=attrs)
    pad = SMPLX_V - len(nv_)                              # unreferenced filler vertices to hit 10,475 exactly
    def padded(x):
        return np.concatenate([x, np.repeat(x[:1], pad, 0)]) if pad else x
    V = SMPLX_V
    w = padded(at["w"])
    w = w / w.sum(1, keepdims=True)
    jr = np.zeros((55, V), np.float32)
    jr[:, :V0] = a["J_regressor"]                         # original vertices keep their indices
    rng = np.random.default_rng(0)
    out = {k: a[k] for k in ("kintree_table", "hands_componentsl", "hands_componentsr", "hands_meanl",
                             "hands_meanr", "lmk_bary_coords", "vertex_id_names", "vertex_id_values")}
    out.update(v_template=padded(nv_).astype(np.float32), f=nf_.astype(np.int32), J_regressor=jr,
               weights=w.astype(np.float32), shapedirs=padded(at["s"]).reshape(V, 3, -1).astype(np.float32),
               posedirs=(rng.normal(size=(V, 3, 486)) * 1e-5).astype(np.float32),
               lmk_faces_idx=np.minimum(a["lmk_faces_idx"], len(nf_) - 1))
    np.savez(path, **out)
    return path


def load_motion(frames: int):
    from gesturelsm.motion import MotionSequence

    p = SHARED / "smplxflame_30" / f"{TAKE}.npz"
    if p.exists():
        seq = MotionSequence.load(p)
        reps = -(-frames // seq.num_frames)
        if reps > 1:
            seq = MotionSequence(np.tile(seq.poses, (reps, 1)), np.tile(seq.trans, (reps, 1)),
                                 np.tile(seq.expressions, (reps, 1)), seq.betas)
        return seq.slice(0, frames), f"BEAT2 {TAKE}"
    rng = np.random.default_rng(0)
    t = np.arange(frames)[:, None] / 30
    poses = 0.3 * np.sin(2 * np.pi * rng.uniform(0.2, 1.5, (1, 165)) * t + rng.uniform(0, 6, (1, 165)))
    return MotionSequence(poses, np.tile([0.0, 1.3, 0.0], (frames, 1)), np.zeros((frames, 100))), "synthetic"


def measure_fps(seqs, body, size: int, labels, character=None) -> tuple[float, float]:
    """(fps from the median frame time, CPU ms per frame) over all frames but the first."""
    from gesturelsm.render import iter_frames

    it = iter_frames(seqs, body=body, size=(size, size), labels=labels, character=character)
    next(it)
    dts, c0 = [], time.process_time()
    t = time.perf_counter()
    for _ in it:
        now = time.perf_counter()
        dts.append(now - t)
        t = now
    cpu = (time.process_time() - c0) / max(len(dts), 1)
    return 1.0 / statistics.median(dts), cpu * 1000


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=90, help="frames per fps measurement")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--quick", action="store_true", help="skip the 60 s clip")
    ap.add_argument("--rig", help="a character (.vrm / .glb): also measure its own mesh")
    args = ap.parse_args()

    from gesturelsm.body import load_body_model
    from gesturelsm.render import render_video, select_platform

    backend = select_platform()
    cores = os.cpu_count() or 1
    seq, source = load_motion(max(args.frames + 1, 1800))
    part = seq.slice(300, 300 + args.frames + 1)
    with tempfile.TemporaryDirectory() as tmp:
        bodies = {"mannequin (7,534 v)": load_body_model(),
                  "SMPL-X-sized (10,475 v)": load_body_model(build_10k_body(Path(tmp) / "SMPLX_10K.npz"))}
        print(f"backend {backend}, {cores} cores, load average {os.getloadavg()[0]:.2f}, motion: {source}\n")
        print("| body | bodies | size | fps | cpu ms/frame | fps if idle |")
        print("|---|---|---|---|---|---|")
        figures = [(name, body, None) for name, body in bodies.items()]
        if args.rig:
            from gesturelsm.retarget import load_character
            from gesturelsm.retarget.mesh import character_mesh

            character = load_character(args.rig)
            v = character_mesh(character.document, character.skeleton).num_vertices
            figures.append((f"{character.name} ({v:,} v)", bodies["mannequin (7,534 v)"], character))
        for name, body, character in figures:
            for n in (1, 3):
                seqs = [part] * n if n == 1 else [part, part.mirrored(), part.slice(0, part.num_frames)]
                labels = None if n == 1 else ["GestureLSM 8 steps", "rectified flow 8", "ground truth"]
                fps, cpu = measure_fps(seqs, body, args.size, labels, character)
                print(f"| {name} | {n} | {args.size * n}x{args.size} | {fps:.1f} | {cpu:.0f} | "
                      f"{1000 * cores / cpu:.0f} |", flush=True)
        print("\n| clip | figure | bodies | size | render + encode s | x real time |")
        print("|---|---|---|---|---|---|")
        y = (0.1 * np.sin(np.arange(60 * 16000) / 16000 * 2 * np.pi * 220)).astype(np.float32)
        for name, body, character in [f for f in figures if f[0] != "SMPL-X-sized (10,475 v)"]:
            for secs in (10,) if args.quick else (10, 60):
                clip = seq.slice(0, secs * 30)
                t0 = time.perf_counter()
                render_video([clip], y[: secs * 16000], Path(tmp) / f"clip{secs}.mp4", size=(args.size, args.size),
                             body=body, character=character)
                dt = time.perf_counter() - t0
                print(f"| {secs} s | {name} | 1 | {args.size}x{args.size} | {dt:.1f} | {secs / dt:.2f} |", flush=True)
        print(f"\nload average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
