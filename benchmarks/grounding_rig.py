"""Feet on the ground on a character: every method's motion on `--rig` (default cryptovoxels.vrm), before and
after grounding, measured on the character's own joints (markdown table out).

    .venv/bin/python benchmarks/grounding_rig.py                                  # cryptovoxels.vrm, 4 recordings
    .venv/bin/python benchmarks/grounding_rig.py --rig avatar.vrm --methods gesturelsm --steps 8

Recordings: the held-out takes' speech (`--takes`, BEAT2 wave16k in ../shared, with their TextGrid transcripts),
each cut into `--parts` equal parts (default 2 takes x 2 parts = 4 recordings of ~31-34 s). Every method generates
on each (`--steps`, seed 0, the default smoothing); the speaker's row is the real take (2_scott_0_1_1). Rows:
- before: the decoder's motion (smoothed) retargeted onto the character, no grounding anywhere;
- SMPL-X only: grounded on the SMPL-X body (gesturelsm.grounding), then retargeted: the character's other leg
  proportions make its feet slide again;
- after: what the page, the videos and the files show on a character: grounded on the SMPL-X body, retargeted,
  and grounded again on the character's own legs (gesturelsm/retarget/grounding.py).
Measures (gesturelsm/metrics/feet.py, on the character's joints in SMPL-X order: `retarget.grounding.smplx_joints`,
the character's units, metres for a glTF / VRM): foot skate, contact share, root drift per minute and range, bob,
floor penetration p99, leg jerk; and the upper body's gesture space (metrics/amplitude.py): raised share, p95 wrist
height, wrist speed. Each is the mean over the recordings. The bars (issue: feet on the ground) are printed under
the table with whether `after` meets them: foot skate <= the speaker's `before` (the real take, measured the same
way), contact share >= 50 %, drift <= 0.3 m/min, range <= 1.5 m, penetration <= 1 cm, bob <= the speaker's
`before`, leg jerk <= `before` + 10 %, gesture space within 2 % of `before`.
Generated motions are kept in `--cache` (npz), so a second run measures without generating again.
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import replace
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from gesturelsm.align.textgrid import read_words  # noqa: E402
from gesturelsm.audio import load_audio  # noqa: E402
from gesturelsm.grounding import ground_motion  # noqa: E402
from gesturelsm.metrics.amplitude import amplitude_stats  # noqa: E402
from gesturelsm.metrics.feet import feet_stats  # noqa: E402
from gesturelsm.motion import MotionSequence  # noqa: E402
from gesturelsm.motion.postprocess import DEFAULT_SMOOTHING, postprocess  # noqa: E402
from gesturelsm.retarget import load_character, retarget_motion  # noqa: E402
from gesturelsm.retarget.grounding import smplx_joints  # noqa: E402

BEAT2 = REPO.parent / "shared" / "data" / "beat2"
VRM = REPO.parent / "shared" / "assets" / "characters" / "cryptovoxels.vrm"
SPEAKER = "2_scott_0_1_1"
STAGES = ("before", "SMPL-X only", "after")
COLUMNS = (("foot skate (cm/s)", "foot_skate", "{:.1f}"), ("contact share", "contact_share", "{:.2f}"),
           ("drift (m/min)", "drift_per_min", "{:.2f}"), ("range (m)", "root_range", "{:.2f}"),
           ("bob (cm)", "bob", "{:.1f}"), ("penetration p99 (cm)", "penetration", "{:.1f}"),
           ("leg jerk (m/s^3)", "leg_jerk", "{:.0f}"), ("raised", "raised_share", "{:.3f}"),
           ("p95 wrist height (m)", "height_p95", "{:.3f}"), ("wrist speed (m/s)", "wrist_speed", "{:.3f}"))


def recordings(takes: list[str], parts: int) -> list[tuple[str, np.ndarray, list]]:
    """(name, 16 kHz speech, its words with times from the take's start) of each part of each take."""
    out = []
    for take in takes:
        y = load_audio(BEAT2 / "wave16k" / f"{take}.wav")
        words = read_words(BEAT2 / "textgrid" / f"{take}.TextGrid")
        n = len(y) // parts
        for k in range(parts):
            a, b = k * n / 16000, (k + 1) * n / 16000
            part = [replace(w, start=w.start - a, end=w.end - a) for w in words if a <= w.start and w.end <= b]
            out.append((f"{take}[{k + 1}/{parts}]", y[k * n:(k + 1) * n], part))
    return out


def generated(pipe, method: str, name: str, y: np.ndarray, words: list, steps: int, cache: Path) -> MotionSequence:
    path = cache / f"{method}_{steps}_{name.replace('/', 'of').replace('[', '_').replace(']', '')}.npz"
    if path.exists():
        return MotionSequence.load(path)
    seq = pipe.generate(y, 16000, words=words, steps=steps, seed=0, method=method, transcribe=False).motion
    seq.save(path)
    return seq


def measures(seq: MotionSequence, character) -> dict[str, dict[str, float]]:
    """{stage: {measure: value}} of one motion on the character (module docstring)."""
    raw = postprocess(seq, False, DEFAULT_SMOOTHING)
    g = ground_motion(raw)
    if g.note:
        print(f"  note: {g.note}")
    rows = {"before": retarget_motion(raw, character, grounding=False),
            "SMPL-X only": retarget_motion(g.motion, character, grounding=False),
            "after": retarget_motion(g.motion, character)}
    out = {}
    for stage, r in rows.items():
        if r.note:
            print(f"  note: {r.note}")
        j = smplx_joints(r)
        out[stage] = {**feet_stats(j).as_dict(), **amplitude_stats(j).as_dict()}
    return out


def mean_of(rows: list[dict]) -> dict[str, dict[str, float]]:
    return {s: {k: float(np.nanmean([r[s][k] for r in rows])) for k in rows[0][s]} for s in STAGES}


def bars(m: dict, speaker: dict) -> list[str]:
    """Which of the issue's bars `after` meets for one method's means."""
    a, b = m["after"], m["before"]
    checks = [("foot skate <= speaker", a["foot_skate"] <= speaker["before"]["foot_skate"]),
              ("contact >= 50 %", a["contact_share"] >= 0.5), ("drift <= 0.3 m/min", a["drift_per_min"] <= 0.3),
              ("range <= 1.5 m", a["root_range"] <= 1.5), ("penetration <= 1 cm", a["penetration"] <= 1.0),
              ("bob <= speaker", a["bob"] <= speaker["before"]["bob"]),
              ("leg jerk <= before + 10 %", a["leg_jerk"] <= 1.1 * b["leg_jerk"])]
    checks += [(f"{k} within 2 %", abs(a[k] - b[k]) <= 0.02 * abs(b[k])) for k in ("raised_share", "height_p95",
                                                                                 "wrist_speed")]
    return [f"{name}: {'yes' if ok else 'NO'}" for name, ok in checks]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rig", default=str(VRM), help="the character (.vrm / .glb / .gltf / .bvh)")
    ap.add_argument("--takes", nargs="+", default=["2_scott_0_2_2", "2_scott_0_3_3"])
    ap.add_argument("--parts", type=int, default=2, help="each take cut into this many recordings")
    ap.add_argument("--methods", nargs="+", default=None, help="default: every shipped generator")
    ap.add_argument("--steps", type=int, default=8)
    ap.add_argument("--cache", default=str(REPO / ".cache" / "grounding_rig"))
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args()
    import torch

    from gesturelsm.pipeline import GesturePipeline

    torch.set_num_threads(args.threads)
    character = load_character(args.rig)
    cache = Path(args.cache)
    cache.mkdir(parents=True, exist_ok=True)
    pipe = GesturePipeline.from_pretrained(methods=args.methods, warm_up=False)
    methods = list(pipe.generators)
    t0 = time.perf_counter()
    table = {"speaker (real take)": mean_of([measures(MotionSequence.load(BEAT2 / "smplxflame_30" / f"{SPEAKER}.npz"),
                                                      character)])}
    recs = recordings(args.takes, args.parts)
    for method in methods:
        table[method] = mean_of([measures(generated(pipe, method, n, y, w, args.steps, cache), character)
                                 for n, y, w in recs])
    print(f"{character.name} ({len(character.skeleton.bones)} humanoid bones); {len(recs)} recordings "
          f"({', '.join(n for n, _, _ in recs)}); {args.steps} steps, seed 0; measured on the character's own joints "
          f"({time.perf_counter() - t0:.0f} s)\n")
    print("| method | stage | " + " | ".join(c for c, _, _ in COLUMNS) + " |")
    print("|---|---|" + "---|" * len(COLUMNS))
    for method, m in table.items():
        for stage in STAGES:
            print(f"| {method} | {stage} | " + " | ".join(f.format(m[stage][k]) for _, k, f in COLUMNS) + " |")
    print()
    speaker = table["speaker (real take)"]
    for method, m in table.items():
        print(f"- {method}, after: " + "; ".join(bars(m, speaker)))


if __name__ == "__main__":
    main()
