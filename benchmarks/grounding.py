"""Feet on the ground, before and after, per method, on held-out speech (docs/GROUNDING.md).

    .venv/bin/python benchmarks/grounding.py [--checkpoints assets] [--methods ...] [--seed 0]
                                            [--plot docs/grounding.png] [--out runs/grounding]
    .venv/bin/python benchmarks/grounding.py --rig ../shared/assets/characters/cryptovoxels.vrm   # on a character

Speech no training uses (assets/MODEL_CARD.md): BEAT2 2_scott_0_2_2 and 2_scott_0_3_3 (62 s, 68 s; speech and
TextGrid only), the last 20 % of 2_scott_0_1_1 (12.7 s: its first 80 % trains the shipped models), and, as a
fourth recording, 30 s of synthetic speech (eSpeak NG, en-us) of a paragraph written for this benchmark (../shared
holds no other speech of the speaker). Each method generates as `gesturelsm generate` does by default (its default
steps, CFG 2, the seed, light smoothing; the words from the TextGrid, the synthetic speech's from eSpeak), and is
measured without grounding (`--grounding off`) and with it (the default), on the shipped mannequin's world joints:
metrics/feet.py (foot skate, contact share, drift per minute, range, bob, floor penetration, leg jerk) and
metrics/amplitude.py (raised share, wrist height p95, wrist speed), and the median knee flexion (degrees between thigh
and shin, grounding/motion.py `knee_flexion`). The real take's rows: the whole 2_scott_0_1_1
motion (64 s) as recorded and grounded.

The bars (the feet issue), each checked per recording: foot skate <= the real take's, contact share >= 0.5, drift
<= 0.3 m/min, range <= 1.5 m, penetration <= 1 cm, bob <= the real take's, leg jerk <= ungrounded + 10 %, raised
share / wrist height p95 / wrist speed within 2 % of ungrounded, knee flexion within 3 degrees of ungrounded and at
most 14 (standing straight, the default). `--lowest` grounds with GroundingSettings(straight=False), the root as
low as the lowest-reaching planted leg asks (`--straight` names the default). Cost: grounding each take on one
core (this process pinned to one CPU, torch on one thread), median of `--repeats`, per 60 s of motion.

With `--rig CHARACTER` the same table is measured on the character's own joints: each motion retargeted onto it
(before: the ungrounded motion as retargeted; after: the grounded motion grounded again on the character's own legs,
as the page, the videos and the files show it; gesturelsm/retarget/grounding.py), the real take's rows too, in the
character's units (metres for a VRM / glTF).
"""
from __future__ import annotations

from _harness import BEAT2, cpu_name, set_threads

import argparse
import os
import sys
import time
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):     # one core: before numpy loads
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from gesturelsm.evaluation.motion_stats import stats_body  # noqa: E402
from gesturelsm.grounding.motion import knee_flexion  # noqa: E402
from gesturelsm.metrics.amplitude import amplitude_stats  # noqa: E402
from gesturelsm.metrics.feet import feet_stats  # noqa: E402
from gesturelsm.motion import MotionSequence  # noqa: E402
from gesturelsm.pipeline import finish  # noqa: E402

TAKE = "2_scott_0_1_1"
PARAGRAPH = ("so the question people keep asking me is whether any of this actually works outside the lab and my "
             "honest answer is that it depends on what you are willing to measure. we started with a small group "
             "of volunteers who agreed to wear the sensors for a whole week at home and at work, and what surprised "
             "us most was not the data itself but how quickly everyone forgot they were wearing anything at all. by "
             "the third day the numbers looked completely different, calmer and more regular, and that told us the "
             "first two days were mostly people performing for the equipment rather than living their lives.")
MEASURES = (("foot_skate", "skate cm/s", "{:.1f}"), ("contact_share", "contact", "{:.2f}"),
            ("drift_per_min", "drift m/min", "{:.2f}"), ("root_range", "range m", "{:.2f}"),
            ("bob", "bob cm", "{:.1f}"),
            ("penetration", "pen. p99 cm", "{:.1f}"), ("leg_jerk", "leg jerk m/s³", "{:.1f}"),
            ("raised_share", "raised", "{:.3f}"), ("height_p95", "wrist p95 m", "{:.3f}"),
            ("wrist_speed", "wrist m/s", "{:.3f}"), ("knee_flexion", "knee °", "{:.1f}"))


SETTINGS: list = [None]          # GroundingSettings for grounded(); None: the default


def grounded(seq: MotionSequence) -> tuple[MotionSequence, str | None]:
    """`seq` (smoothed as shipped) with its feet on the ground, as `finish(..., grounding=True)` does, with
    SETTINGS[0] when set (--straight, --lowest)."""
    if SETTINGS[0] is None:
        return finish(seq, grounding=True)
    from gesturelsm.grounding import ground_motion

    res = ground_motion(seq, settings=SETTINGS[0])
    return res.motion, res.warning


def measure(seq: MotionSequence) -> dict[str, float]:
    j = stats_body().joints(seq.poses, seq.trans)
    a = amplitude_stats(j)
    return {**feet_stats(j).as_dict(), "raised_share": a.raised_share, "height_p95": a.height_p95,
            "wrist_speed": a.wrist_speed, "knee_flexion": knee_flexion(j)}


def on_rig(character, grounding: bool):
    """`measure` on a character's own joints (gesturelsm/retarget/grounding.py `smplx_joints`, its world units:
    metres for a glTF / VRM): the motion retargeted onto it, its feet planted on its own legs when `grounding`."""
    from gesturelsm.retarget import retarget_motion
    from gesturelsm.retarget.grounding import smplx_joints

    def measure_on(seq: MotionSequence) -> dict[str, float]:
        r = retarget_motion(seq, character, grounding=grounding)
        if r.note:
            print(f"  {r.note}", flush=True)
        j = smplx_joints(r)
        a = amplitude_stats(j)
        return {**feet_stats(j).as_dict(), "raised_share": a.raised_share, "height_p95": a.height_p95,
                "wrist_speed": a.wrist_speed, "knee_flexion": knee_flexion(j)}
    return measure_on


def rig_stats(runs: list[dict], take: MotionSequence, path: str) -> tuple[tuple[dict, dict], str]:
    """--rig: every run's before / after measured on the character (before: the ungrounded motion retargeted as it
    is; after: the grounded motion grounded again on the character's legs, what every output on a character shows),
    the real take's rows the same way, and a line per method with the foot skate of the grounded motion retargeted
    without the character's own grounding (what its other leg proportions leave)."""
    from gesturelsm.retarget import load_character

    character = load_character(path)
    before, after, smplx_only = on_rig(character, False), on_rig(character, True), {}
    for r in runs:
        r["before_stats"], r["after_stats"] = before(r["before"]), after(r["after"])
        smplx_only.setdefault(r["method"], []).append(before(r["after"])["foot_skate"])
    grounded = finish(take, grounding=True)[0]
    real = (before(take), after(grounded))
    smplx_only["real take"] = [before(grounded)["foot_skate"]]
    line = (f"On {character.name}, measured on its own joints. Grounded on the SMPL-X body only, its legs as "
            "retargeted, the foot skate would be: " + ", ".join(f"{m} {np.mean(v):.1f} cm/s"
                                                                 for m, v in smplx_only.items()) + ".")
    return real, line


def recordings() -> list[tuple[str, np.ndarray, list | None]]:
    """(name, 16 kHz speech, words or None) of the held-out speech."""
    from gesturelsm.align.textgrid import read_words
    from gesturelsm.align.tts import synthesize
    from gesturelsm.align.words import Word
    from gesturelsm.audio import load_audio, resample

    out = []
    for name in ("2_scott_0_2_2", "2_scott_0_3_3"):
        out.append((name, load_audio(BEAT2 / "wave16k" / f"{name}.wav"),
                    read_words(BEAT2 / "textgrid" / f"{name}.TextGrid")))
    audio = load_audio(BEAT2 / "wave16k" / f"{TAKE}.wav")
    n = len(MotionSequence.load(BEAT2 / "smplxflame_30" / f"{TAKE}.npz").poses)
    start = int(0.8 * n)                                            # the held-out 20 % of the motion take
    a, b = start * 16000 // 30, n * 16000 // 30
    words = [Word(w.text, w.start - start / 30, w.end - start / 30) for w in
             read_words(BEAT2 / "textgrid" / f"{TAKE}.TextGrid") if w.start >= start / 30 and w.end <= n / 30]
    out.append((f"{TAKE} last 20 %", audio[a:b], words))
    syn = synthesize(PARAGRAPH.split())[0]
    starts = list(syn.starts) + [len(syn.audio) / syn.sr]
    words = [Word(w, float(s), float(e)) for w, s, e in zip(PARAGRAPH.split(), starts[:-1], starts[1:])]
    out.append(("synthetic speech (eSpeak NG)", resample(syn.audio, syn.sr, 16000), words))
    return out


def one_core_seconds(seq: MotionSequence, repeats: int) -> tuple[float, float]:
    """Median (wall, CPU) seconds to ground `seq` with this process pinned to one CPU."""
    from gesturelsm.grounding import ground_motion

    cpus = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {min(cpus)})
    try:
        ground_motion(seq)                                          # the body's rig, cached
        wall, cpu = [], []
        for _ in range(repeats):
            t0, c0 = time.perf_counter(), time.process_time()
            ground_motion(seq)
            wall.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
    finally:
        os.sched_setaffinity(0, cpus)
    return float(np.median(wall)), float(np.median(cpu))



def generate(pipe, methods: list[str], seed: int) -> list[dict]:
    """Per recording and method: the light-smoothed motion before grounding and after."""
    from gesturelsm.backends import SPECS
    from gesturelsm.motion.postprocess import DEFAULT_SMOOTHING

    runs = []
    for name, audio, words in recordings():
        speech = pipe.prepare_speech(audio, 16000, words=words)
        for m in methods:
            t0 = time.perf_counter()
            res = pipe.generate(speech, steps=SPECS[m].default_steps, cfg=2.0, seed=seed, method=m, output="raw")
            raw = res.motion.slice(0, speech.num_frames)
            before, _ = finish(raw, False, DEFAULT_SMOOTHING, False)
            after, note = grounded(before)
            runs.append(dict(recording=name, method=m, seconds=before.duration, before=before, after=after, note=note))
            print(f"  {name}: {m} in {time.perf_counter() - t0:.1f} s{'; ' + note if note else ''}", flush=True)
    return runs


def bars(real: dict, before: dict, after: dict) -> list[str]:
    """The issue's bars this grounded motion misses (empty: all met)."""
    checks = [("foot skate", after["foot_skate"] <= real["foot_skate"]), ("contact", after["contact_share"] >= 0.5),
              ("drift", after["drift_per_min"] <= 0.3), ("range", after["root_range"] <= 1.5),
              ("penetration", after["penetration"] <= 1.0), ("bob", after["bob"] <= real["bob"]),
              ("leg jerk", after["leg_jerk"] <= 1.1 * before["leg_jerk"]),
              ("knee", abs(after["knee_flexion"] - before["knee_flexion"]) <= 3.0 and after["knee_flexion"] <= 14.0)]
    checks += [(k, abs(after[k] - before[k]) <= 0.02 * abs(before[k])) for k in ("raised_share", "height_p95",
                                                                             "wrist_speed")]
    return [name for name, ok in checks if not ok]


def row(cells: list[str]) -> str:
    return "| " + " | ".join(cells) + " |"


def table(runs: list[dict], real: tuple[dict, dict], cost: dict) -> str:
    """The markdown: per method, before and after, every measure as the mean over recordings (worst recording for
    the bars), then per recording."""
    head = ["method", "", *(c[1] for c in MEASURES), "bars missed"]
    lines = [row(head), "|" + "---|" * len(head)]
    lines.append(row(["real take (2_scott_0_1_1)", "recorded", *(f.format(real[0][k]) for k, _, f in MEASURES), "-"]))
    lines.append(row(["", "grounded", *(f.format(real[1][k]) for k, _, f in MEASURES),
                      ", ".join(bars(real[0], real[0], real[1])) or "none"]))
    for m in dict.fromkeys(r["method"] for r in runs):
        mine = [r for r in runs if r["method"] == m]
        for when in ("before", "after"):
            mean = {k: float(np.mean([r[when + "_stats"][k] for r in mine])) for k, _, _ in MEASURES}
            missed = sorted({b for r in mine for b in bars(real[0], r["before_stats"], r["after_stats"])})
            note = ("; ".join(missed) or "none") if when == "after" else "-"
            lines.append(row([m if when == "before" else "", "ungrounded" if when == "before" else "grounded",
                              *(f.format(mean[k]) for k, _, f in MEASURES), note]))
    lines += ["", "Per recording (grounded; bars missed):", ""]
    for r in runs:
        missed = bars(real[0], r["before_stats"], r["after_stats"])
        lines.append(f"- {r['recording']} ({r['seconds']:.1f} s), {r['method']}: skate "
                     f"{r['before_stats']['foot_skate']:.1f} -> {r['after_stats']['foot_skate']:.1f} cm/s, drift "
                     f"{r['before_stats']['drift_per_min']:.2f} -> {r['after_stats']['drift_per_min']:.2f} m/min, "
                     "range "
                     f"{r['before_stats']['root_range']:.2f} -> {r['after_stats']['root_range']:.2f} m, bob "
                     f"{r['before_stats']['bob']:.1f} -> {r['after_stats']['bob']:.1f} cm, knee "
                     f"{r['before_stats']['knee_flexion']:.1f} -> {r['after_stats']['knee_flexion']:.1f}°; "
                     f"{', '.join(missed) or 'all bars met'}{'; ' + r['note'] if r['note'] else ''}")
    lines += ["", f"Cost on one core: {cost['per_minute']:.3f} s per 60 s of motion, wall clock "
              f"({cost['cpu_per_minute']:.3f} "
              f"s of CPU time); median over {cost['takes']} takes of the median of {cost['repeats']} runs each; "
              f"{cost['cpu']}, load average {cost['load']:.1f} when measured."]
    return "\n".join(lines)


def trace_plot(run: dict, path: Path) -> None:
    """Top-down paths of the pelvis and both ankles, ungrounded and grounded (the same frames)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(8.0, 4.2), dpi=100, sharex=True, sharey=True)
    for ax, when, title in zip(axes, ("before", "after"), ("ungrounded", "grounded")):
        j = stats_body().joints(run[when].poses, run[when].trans)
        for idx, name, color in ((0, "pelvis", "k"), (7, "left ankle", "tab:blue"), (8, "right ankle", "tab:orange")):
            ax.plot(j[:, idx, 0], j[:, idx, 2], color=color, lw=0.8, label=name)
            ax.plot(j[0, idx, 0], j[0, idx, 2], "o", color=color, ms=4)
        s = run[when + "_stats"]
        ax.set_title(f"{title}: skate {s['foot_skate']:.1f} cm/s, drift {s['drift_per_min']:.2f} m/min", fontsize=8)
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
        ax.set_xlabel("x (m, the body's left)")
    axes[0].set_ylabel("z (m, the body's front)")
    axes[0].legend(fontsize=7, loc="best")
    fig.suptitle(f"{run['method']}, {run['recording']} ({run['seconds']:.0f} s), seen from above; dots: the start",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--checkpoints", default=None)
    ap.add_argument("--methods", nargs="+", default=None, help="default: every method the checkpoints provide")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--plot", default=None, help="write the top-down trace of the first method's first recording here")
    ap.add_argument("--out", default=None, help="folder for grounding.md")
    ap.add_argument("--rig", default=None, help="measure on this character's own joints (.vrm / .glb / .gltf / .bvh): "
                    "the motions retargeted onto it, after = grounded again on its own legs")
    ap.add_argument("--straight", action="store_true", help="ground with GroundingSettings(straight=True): the knees "
                    "as straight as the motion had them (the default; kept for old command lines)")
    ap.add_argument("--lowest", action="store_true", help="ground with GroundingSettings(straight=False): the root as "
                    "low as the lowest-reaching planted leg asks (knees about twice as bent as the motion had them)")
    args = ap.parse_args()

    if args.straight or args.lowest:
        from gesturelsm.grounding import GroundingSettings

        SETTINGS[0] = GroundingSettings(straight=not args.lowest)

    from gesturelsm.backends import checkpoint_sources
    from gesturelsm.pipeline import GesturePipeline

    set_threads(1)
    if not (BEAT2 / "smplxflame_30" / f"{TAKE}.npz").exists():
        print(f"{BEAT2} is absent: the held-out speech and the real take live in ../shared", file=sys.stderr)
        return 2
    pipe = GesturePipeline.from_pretrained(checkpoints=checkpoint_sources(args.checkpoints), methods=args.methods)
    runs = generate(pipe, args.methods or pipe.methods, args.seed)
    take = MotionSequence.load(BEAT2 / "smplxflame_30" / f"{TAKE}.npz")
    rig_line = ""
    if args.rig:
        real, rig_line = rig_stats(runs, take, args.rig)
    else:
        for r in runs:
            r["before_stats"], r["after_stats"] = measure(r["before"]), measure(r["after"])
        real = (measure(take), measure(grounded(take)[0]))
    long = [r["before"] for r in runs if r["seconds"] >= 30][:4]
    per = np.array([one_core_seconds(seq, args.repeats) for seq in long]) / [[s.duration / 60] for s in long]
    cost = dict(per_minute=float(np.median(per[:, 0])), cpu_per_minute=float(np.median(per[:, 1])),
                repeats=args.repeats, takes=len(long), cpu=cpu_name(), load=os.getloadavg()[0])
    md = (f"Seed {args.seed}; {len({r['recording'] for r in runs})} recordings x {len(set(r['method'] for r in runs))} "
          "methods; means over recordings, bars checked on each.\n\n" + table(runs, real, cost)
          + (f"\n\n{rig_line}" if rig_line else ""))
    print(md)
    if args.out:
        Path(args.out).mkdir(parents=True, exist_ok=True)
        (Path(args.out) / "grounding.md").write_text(md + "\n")
    if args.plot:
        trace_plot(runs[0], Path(args.plot))
        print(f"wrote {args.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
