"""The before/after picture of docs/EDITING.md: the real BEAT2 take's own motion, and the same take with its upper
body and hands regenerated over 8-11 s by the shipped GestureLSM (seed 1) with a keyframe at 9.5 s posed as the
take's frame 408 (both hands raised, at 13.6 s). Top: the mannequin at four times, before (input) and after (edited);
bottom: the right elbow's bend and the right wrist's height over time, before and after, with the range
and the keyframe marked.

    .venv/bin/python scripts/edit_picture.py [--out docs/editing.png]
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
REPO = Path(__file__).resolve().parents[1]
BEAT2 = REPO.parent / "shared" / "data" / "beat2"
TAKE = "2_scott_0_1_1"
SECONDS, A, B, KEY_TIME, KEY_FRAME, SEED = 20, 8.0, 11.0, 9.5, 408, 1     # frame 408: both hands raised
TIMES = (7.5, 8.8, 9.5, 10.5)


def edited():
    from gesturelsm.audio import load_audio
    from gesturelsm.motion import MotionSequence
    from gesturelsm.pipeline import GesturePipeline

    take = MotionSequence.load(BEAT2 / "smplxflame_30" / f"{TAKE}.npz")
    audio = load_audio(BEAT2 / "wave16k" / f"{TAKE}.wav")[:16000 * SECONDS]
    pipe = GesturePipeline.from_pretrained(methods=["gesturelsm"])
    before = take.slice(0, 30 * SECONDS)
    res = pipe.edit(before, audio, {"upper": [(A, B)], "hands": [(A, B)]}, keyframes=[(KEY_TIME, (take, KEY_FRAME))],
                    seed=SEED, transcribe=False)
    return before, res.motion


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(REPO / "docs" / "editing.png"))
    args = ap.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from gesturelsm.body import load_body_model
    from gesturelsm.render.frames import fit_camera, render_frames

    before, after = edited()
    body = load_body_model()
    frames = [int(t * 30) for t in TIMES]
    cam = fit_camera([before, after], body=body)
    tiles = {name: render_frames([m], frames, body=body, size=(320, 320), camera=cam)
             for name, m in (("before", before), ("after", after))}
    fig = plt.figure(figsize=(12, 8.4), dpi=100)
    grid = fig.add_gridspec(3, len(TIMES), height_ratios=[1, 1, 0.9])
    for row, name in enumerate(("before", "after")):
        for col, (t, img) in enumerate(zip(TIMES, tiles[name])):
            ax = fig.add_subplot(grid[row, col])
            ax.imshow(img)
            ax.set_xticks([]), ax.set_yticks([])
            ax.set_title(f"{name}, {t:.1f} s" + (" (keyframe)" if t == KEY_TIME and name == "after" else ""),
                         fontsize=10)
    ax = fig.add_subplot(grid[2, :])
    jb, ja = body.joints(before.poses, before.trans), body.joints(after.poses, after.trans)
    t = np.arange(before.num_frames) / 30
    elbow = lambda p: np.degrees(np.linalg.norm(p.reshape(-1, 55, 3)[:, 19], axis=1))  # noqa: E731 right elbow bend
    ax.plot(t, elbow(before.poses), color="0.55", label="right elbow bend, before (deg)")
    ax.plot(t, elbow(after.poses), color="C0", label="right elbow bend, after (deg)")
    ax2 = ax.twinx()
    ax2.plot(t, jb[:, 21, 1] * 100, color="0.55", ls="--", label="right wrist height, before (cm)")
    ax2.plot(t, ja[:, 21, 1] * 100, color="C1", ls="--", label="right wrist height, after (cm)")
    ax.axvspan(A, B, color="C2", alpha=0.12, label="regenerated: upper + hands")
    ax.axvline(KEY_TIME, color="C3", lw=1, label="keyframe")
    ax.set_xlim(A - 3, B + 3)
    ax.set_xlabel("time (s)")
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="upper left", ncol=2)
    fig.suptitle(f"BEAT2 {TAKE}: upper body and hands regenerated over {A:g}-{B:g} s (GestureLSM, seed {SEED}), "
                 f"keyframe at {KEY_TIME:g} s = the take's frame {KEY_FRAME}\n"
                 "everything else is the take's own motion, "
                 "bit for bit", fontsize=10)
    fig.tight_layout()
    fig.savefig(args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
