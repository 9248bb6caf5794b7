"""The motion the per-length benchmarks time: the real BEAT2 take from ../shared looped to a length, else smooth
random motion of the same length (its expressions move too, so face measurements have something to read)."""
from __future__ import annotations

from _harness import BEAT2, set_threads


import numpy as np

from gesturelsm.motion import MotionSequence

TAKE = BEAT2 / "smplxflame_30" / "2_scott_0_1_1.npz"


def looped_motion(seconds: float, amplitude: float = 0.1) -> tuple[MotionSequence, str]:
    """(motion of `seconds` at 30 fps, "BEAT2 take" or "synthetic"); `amplitude`: radians of the synthetic joints."""
    frames = int(round(seconds * 30))
    if TAKE.exists():
        seq = MotionSequence.load(TAKE)
        reps = -(-frames // seq.num_frames)
        tile = lambda a: np.concatenate([a] * reps)[:frames]  # noqa: E731
        return MotionSequence(tile(seq.poses), tile(seq.trans), tile(seq.expressions), seq.betas), "BEAT2 take"
    rng = np.random.default_rng(0)
    t = np.arange(frames)[:, None] / 30
    poses = amplitude * np.sin(2 * np.pi * rng.uniform(0.2, 1.5, (1, 165)) * t + rng.uniform(0, 6, (1, 165)))
    expr = np.sin(2 * np.pi * rng.uniform(0.2, 1.5, (1, 100)) * t)
    return MotionSequence(poses, np.tile([0, 1.3, 0], (frames, 1)), expr), "synthetic"


def length_args(description: str):
    """--seconds (default 60), --repeats (5) and --threads (1, applied to torch) of the per-length benchmarks."""
    import argparse


    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--threads", type=int, default=1, help="torch threads (default 1)")
    args = ap.parse_args()
    set_threads(args.threads)
    return args
