"""What edits do to the motion, measured on the real BEAT2 take's own motion capture with the shipped models.

    .venv/bin/python benchmarks/edit_quality.py [--seeds 3] [--methods gesturelsm rectified_flow ddim]

The first 20 s of 2_scott_0_1_1 (its motion and its speech), edited per method and seed over five ranges of the
upper body and hands (0-2, 3-5, 8-11, 10.1-12.3 and 17-20 s). Per method, over every range, seed and region:
- inside: the mean joint angle between the input and the edit inside the range (degrees);
- outside: the largest joint angle more than 0.5 s outside the range (radians; 0 = the input's bits);
- seam: the largest joint speed within 3 frames of a range's ends over the larger of the motion's own 99th
  percentile (pooled over the region's joints) and the input's own speed at that frame (<= 1: no jump);
- keyframe: a keyframe at the middle of 8-11 s posed as the take's frames 408, 900 and 1400: the largest upper-body
  joint angle to the pose at its frame from the held latents alone (before the final correction), and after it.
Needs ../shared (the BEAT2 sample) and the shipped checkpoints.
"""
from __future__ import annotations

from _harness import BEAT2

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
TAKE, SECONDS = "2_scott_0_1_1", 20
RANGES = [(0.0, 2.0), (3.0, 5.0), (8.0, 11.0), (10.1, 12.3), (17.0, 20.0)]
KEY_FRAMES = (408, 900, 1400)


def _joints(poses, region):
    from gesturelsm.motion.regions import REGIONS

    return poses.reshape(len(poses), 55, 3)[:, list(REGIONS[region].joints)]


def range_figures(pipe, speech, motion, method: str, seed: int) -> list[tuple[float, float, float]]:
    """(inside degrees, outside radians, seam ratio) per range and region."""
    from gesturelsm.motion.merge import joint_angles, joint_speeds

    out = []
    for a, b in RANGES:
        ed = pipe.edit(motion, speech, {"upper": [(a, b)], "hands": [(a, b)]}, method=method, seed=seed).motion
        a0, b0 = round(a * 30), round(b * 30)
        for region in ("upper", "hands"):
            x, y = _joints(motion.poses, region), _joints(ed.poses, region)
            angle = joint_angles(x, y)
            far = np.concatenate([angle[:max(0, a0 - 15)].ravel(), angle[b0 + 15:].ravel(), [0.0]])
            own, new = joint_speeds(x), joint_speeds(y)
            p99 = np.percentile(own, 99)
            seam = max((new[s] / np.maximum(p99, own[s])).max() for s in (slice(max(0, a0 - 3), a0 + 3),
                                                                           slice(b0 - 3, min(len(new), b0 + 3))))
            out.append((float(np.degrees(angle[a0:b0].mean())), float(far.max()), float(seam)))
    return out


def key_figures(pipe, speech, motion, take, method: str, seed: int) -> list[tuple[float, float]]:
    """(degrees from the held latents alone, degrees after the final correction) per keyframe pose."""
    from gesturelsm.motion.editing import edit_spec, keyframe
    from gesturelsm.motion.merge import joint_angles, merge_edit, splice
    from gesturelsm.motion.postprocess import postprocess
    from gesturelsm.motion.regions import REGIONS

    up = list(REGIONS["upper"].joints)
    out = []
    for src in KEY_FRAMES:
        key = keyframe(9.5, (take, src))
        spec = edit_spec({"upper": [(8.0, 11.0)], "hands": [(8.0, 11.0)]}, motion.num_frames, [key])
        raw = pipe.backends[method].edit(speech, motion, spec, pipe.spec(method).default_steps, 2.0, seed)
        held = merge_edit(motion, postprocess(splice(motion, raw.motion, raw.start, spec.regions), False, "light"),
                          spec)
        final = pipe.edit(motion, speech, {"upper": [(8.0, 11.0)], "hands": [(8.0, 11.0)]},
                          keyframes=[(9.5, (take, src))], method=method, seed=seed).motion
        pose = key.pose.reshape(1, 55, 3)[:, up]
        f = key.frame
        out.append(tuple(float(np.degrees(joint_angles(m.poses.reshape(-1, 55, 3)[f:f + 1, up], pose)).max())
                         for m in (held, final)))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--methods", nargs="+", default=["gesturelsm", "rectified_flow", "ddim"])
    args = ap.parse_args()
    from gesturelsm.audio import load_audio
    from gesturelsm.motion import MotionSequence
    from gesturelsm.pipeline import GesturePipeline

    take = MotionSequence.load(BEAT2 / "smplxflame_30" / f"{TAKE}.npz")
    motion = take.slice(0, 30 * SECONDS)
    pipe = GesturePipeline.from_pretrained(methods=args.methods)
    speech = pipe.prepare_speech(load_audio(BEAT2 / "wave16k" / f"{TAKE}.wav")[:16000 * SECONDS], 16000,
                                 transcribe=False)
    print(f"BEAT2 {TAKE}, its first {SECONDS} s; upper + hands over {len(RANGES)} ranges; seeds 1-{args.seeds}\n")
    print("| method | inside: mean joint angle (deg), min / median | outside: max angle (rad) | seam: max speed / "
          "max(p99, input's own) | keyframe from held latents: max upper-body angle (deg), median / max | "
          "after the correction (deg) |")
    print("|---|---|---|---|---|---|")
    for m in args.methods:
        r = [x for s in range(1, args.seeds + 1) for x in range_figures(pipe, speech, motion, m, s)]
        k = [x for s in range(1, args.seeds + 1) for x in key_figures(pipe, speech, motion, take, m, s)]
        inside, outside, seam = (np.array(v) for v in zip(*r))
        held, final = (np.array(v) for v in zip(*k))
        print(f"| {m} | {inside.min():.1f} / {np.median(inside):.1f} | {outside.max():.2g} | {seam.max():.2f} | "
              f"{np.median(held):.1f} / {held.max():.1f} | {final.max():.2g} |", flush=True)


if __name__ == "__main__":
    main()
