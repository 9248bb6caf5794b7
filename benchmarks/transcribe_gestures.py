"""Does the automatic transcript give the gestures the MFA transcript gives? (markdown out)

    NUMBA_CACHE_DIR=.venv/numba-cache .venv/bin/python benchmarks/transcribe_gestures.py [--data DIR] [--seeds 3]

On the held-out BEAT2 take (2_scott_0_1_1, speech + motion) the shipped GestureLSM (8 steps, CFG 2) generates
with: no transcript (audio-only), the automatic transcript (gesturelsm.asr), the MFA TextGrid's words; beside
the speaker's own motion. Statistics per motion (joints by forward kinematics of the mannequin, y up, metres):
share of frames with a wrist above the pelvis + 0.25 m, 95th percentile of the higher wrist's height above the
pelvis, mean wrist speed (m/s, both wrists, 30 fps). Means over seeds.
"""
from __future__ import annotations

from _harness import BEAT2, set_threads

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from gesturelsm.align import read_words  # noqa: E402
from gesturelsm.audio import load_audio  # noqa: E402
from gesturelsm.body import load_body_model  # noqa: E402
from gesturelsm.motion import MotionSequence  # noqa: E402
from gesturelsm.pipeline import GesturePipeline  # noqa: E402

TAKE = "2_scott_0_1_1"
PELVIS, L_WRIST, R_WRIST = 0, 20, 21  # SMPL-X joint ids
RAISED_M = 0.25


def gesture_stats(body, seq: MotionSequence) -> np.ndarray:
    """[share of frames with a raised wrist, p95 wrist height above pelvis (m), mean wrist speed (m/s)]."""
    j = body.joints(seq.poses, seq.trans)                              # (T, 55, 3)
    height = j[:, [L_WRIST, R_WRIST], 1].max(1) - j[:, PELVIS, 1]      # (T,)
    speed = np.linalg.norm(np.diff(j[:, [L_WRIST, R_WRIST]], axis=0), axis=-1).mean() * seq.fps
    return np.array([np.mean(height > RAISED_M), np.percentile(height, 95), speed])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=BEAT2)
    ap.add_argument("--seeds", type=int, default=3)
    args = ap.parse_args()
    if not (args.data / "smplxflame_30" / f"{TAKE}.npz").is_file():
        print(f"no BEAT2 take {TAKE} with motion at {args.data}", file=sys.stderr)
        return 2
    set_threads(1)
    body = load_body_model()
    pipe = GesturePipeline.from_pretrained(methods=["gesturelsm"])
    y = load_audio(args.data / "wave16k" / f"{TAKE}.wav")
    mfa = read_words(args.data / "textgrid" / f"{TAKE}.TextGrid")
    inputs = {"audio-only": pipe.prepare_speech(y, transcribe=False),
              "automatic transcript": pipe.prepare_speech(y),
              "MFA transcript": pipe.prepare_speech(y, words=mfa)}
    print(f"automatic transcript used: {inputs['automatic transcript'].text_mode}\n")
    print(f"| input | frames with a wrist > pelvis + {RAISED_M} m | p95 wrist height above pelvis (m) "
          "| mean wrist speed (m/s) |\n|---|---|---|---|")
    rows = {}
    for name, speech in inputs.items():
        stats = [gesture_stats(body, pipe.generate(speech, steps=8, cfg=2.0, seed=s, output="raw").motion)
                 for s in range(args.seeds)]
        rows[name] = np.mean(stats, 0)
    rows["speaker (BEAT2 motion)"] = gesture_stats(body,
                                                   MotionSequence.load(args.data / "smplxflame_30" / f"{TAKE}.npz"))
    for name, (share, p95, speed) in rows.items():
        print(f"| {name} | {100 * share:.1f} % | {p95:.3f} | {speed:.3f} |")
    a, m = rows["automatic transcript"], rows["MFA transcript"]
    rel = ", ".join(f"{100 * (x - z) / abs(z):+.0f} %" for x, z in zip(a, m))
    print(f"\nautomatic vs MFA transcript, relative difference per column: {rel}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
