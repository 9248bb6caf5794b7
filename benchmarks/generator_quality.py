"""Does generated motion respond to speech? Held-out audio, every method at equal steps.

    .venv/bin/python benchmarks/generator_quality.py [--checkpoints assets] [--seeds 3]

Held-out speech: the last 20% of BEAT2 2_scott_0_1_1 (its motion is ground truth) and the audio-only takes
2_scott_0_2_2 and 2_scott_0_3_3, with their TextGrids (all from ../shared). Per method and step count:
- BC: beat consistency with the speech the motion was generated for (docs/AUTHORS-CODE.md definition, speeds
  normalised by the ground truth's mean joint speeds on the same body);
- BC shuffled: the same motion scored against another take's speech beats. Motion that follows its
  speech scores higher on its own audio than on foreign audio;
- BC gain over shifted speech (metrics.speech_response.beat_timing): BC against its own speech beats minus the
  mean BC against the same beats circularly shifted by 1 s .. (span - 1 s) inside the scored span (same beats,
  wrong timing; motion that ignores speech timing gains 0 on average);
- loudness-following gain (metrics.speech_response.energy_following): correlation of upper-body speed with
  the speech's loudness (1 s averages) minus its mean over the loudness shifted by >= 2 s;
  both gains are shown as mean +- standard error over clips x seeds, with how many clips x seeds gain > 0;
- the speaker's own motion gets both tests on the whole real take (gain and z = gain / spread over shifts):
  what the training data itself shows of these relations;
- speed in silence: 4 s gaps are cut into the speech every 12 s (audio zeroed, words inside dropped) and
  the same seeds generate again; the upper-body speed inside the gaps (from 1 s after the gap starts) over
  the speed in the same spans with speech. 1 means the motion does not notice that the speaker stopped;
- speed: mean upper-body joint speed (m/s) (static motion is ~0), jitter: mean joint acceleration (m/s^2);
- amplitude (metrics.amplitude): raised share (a wrist above pelvis + 0.25 m), wrist height p50/p95,
  wrist speed, hand spread, upper-body jerk, pooled over clips x seeds (with the transcript), beside the
  speaker's whole take, and the replay guard (novelty of 1 s windows against the training motion, over the
  speaker's held-out motion's; copies of training clips score ~0). Audio-only: benchmarks/amplitude_stages.py.
Numbers are means over clips and seeds; ground truth is shown where it exists.

The paper's metrics (FGD, BC beside ground truth's, L1 diversity, face error, jitter, foot skating, time) over
methods x steps x CFG are `gesturelsm eval` (gesturelsm/evaluation/); this script keeps the two checks that
command does not make: BC against foreign speech, and window seams.
"""
from __future__ import annotations

from _harness import BEAT2, set_threads

import argparse
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gesturelsm.align.words import Word
from gesturelsm.body import load_body_model
from gesturelsm.data.beat2 import Beat2Dataset
from gesturelsm.evaluation.amplitude import AmplitudeRow, format_rows
from gesturelsm.generator.sampling import window_layout
from gesturelsm.metrics.amplitude import pooled_stats, replay_novelty, training_bank
from gesturelsm.metrics.beat import audio_beats, beat_consistency, joint_speed
from gesturelsm.metrics.speech_response import beat_timing, energy_following
from gesturelsm.motion.regions import REGIONS
from gesturelsm.pipeline import GesturePipeline

REPO = Path(__file__).resolve().parents[1]
UPPER = list(REGIONS["upper"].joints)
Seams = dict[str, list[tuple[float, float, float, float]]]


@dataclass
class Heldout:
    """The held-out speech: (name, 16 kHz audio, words, ground-truth joints or None) per clip, their beats,
    the speaker's real take, its training part's joints and mean joint speeds (55,) on the body."""
    clips: list[tuple]
    beats: list[np.ndarray]
    take: object
    gt_train: np.ndarray
    mean_speed: np.ndarray


def parse_args() -> argparse.Namespace:
    ap = argparse.ArgumentParser()
    ap.add_argument("--checkpoints", default=None)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--steps", type=int, nargs="+", default=[1, 2, 4, 8])
    ap.add_argument("--cfg", type=float, nargs="+", default=[2.0], help="one or more CFG scales")
    return ap.parse_args()


def load_heldout(body) -> Heldout:
    """The last 20 % of 2_scott_0_1_1 (the first 80 % is the ground truth's training part) and the audio-only takes."""
    ds = Beat2Dataset(BEAT2)
    take = ds.load("2_scott_0_1_1")
    T = take.motion.num_frames
    cut = int(round(0.8 * T)) // 4 * 4
    gt_train = body.joints(take.motion.poses[:cut], take.motion.trans[:cut])
    mean_speed = joint_speed(gt_train).mean(0)                                       # (55,) on this body
    t0 = cut / 30
    clips = [("2_scott_0_1_1 last 20%", take.audio[int(round(cut * 16000 / 30)):],
              [Word(w.text, w.start - t0, w.end - t0) for w in take.words if w.end > t0],
              body.joints(take.motion.poses[cut:], take.motion.trans[cut:]))]
    for name in ds.audio_only_names:
        t = ds.load(name)
        clips.append((name, t.audio, t.words, None))
    return Heldout(clips, [audio_beats(c[1]) for c in clips], take, gt_train, mean_speed)


def clip_stats(j: np.ndarray, i: int, h: Heldout) -> tuple[float, float, float, float, float, float]:
    """Joints (T, 55, 3) made for clip i -> BC own, BC other speech, beat-timing gain, loudness gain, speed, jitter."""
    bc = beat_consistency(j, beats=h.beats[i], mean_speed=h.mean_speed)
    other = h.beats[(i + 1) % len(h.clips)]
    bc_sh = beat_consistency(j, beats=other, mean_speed=h.mean_speed)
    gain = beat_timing(j, h.beats[i], mean_speed=h.mean_speed).gain
    loud = energy_following(j, h.clips[i][1]).gain
    sp = joint_speed(j)[:, UPPER].mean()
    acc = (np.linalg.norm(j[2:] - 2 * j[1:-1] + j[:-2], axis=-1) * 900)[:, UPPER].mean()
    return bc, bc_sh, gain, loud, sp, acc


def with_gaps(audio: np.ndarray, words) -> tuple[np.ndarray, list, list[tuple[float, float]]]:
    """4 s of silence every 12 s (from 6 s on), words inside the gaps dropped: (audio, words, gaps in s)."""
    dur = len(audio) / 16000
    gaps = [(a, a + 4.0) for a in np.arange(6.0, dur - 6.0, 12.0)]
    y = audio.copy()
    for a, b in gaps:
        y[int(a * 16000):int(b * 16000)] = 0
    kept = [w for w in words if not any(w.end > a and w.start < b for a, b in gaps)] if words else words
    return y, kept, gaps


def seam_stats(j: np.ndarray, pipe: GesturePipeline, method: str, seams: Seams) -> None:
    """Per-frame max joint speed change (m/s per frame) near window borders vs inside windows."""
    g = pipe.generators[method].config
    speed = np.linalg.norm(np.diff(j, axis=0), axis=-1) * 30                        # (T-1, 55)
    jump = np.abs(np.diff(speed, axis=0)).max(axis=1)                              # (T-2,)
    borders = [4 * (st + g.seed_latents // 2) for st in window_layout(len(j) // 4, g.window_latents,
                                                                       g.seed_latents)[1:]]
    near = np.zeros(len(jump), bool)
    for b in borders:
        near[max(0, b - 8):b + 8] = True
    if near.any() and (~near).any():
        seams.setdefault(method, []).append((jump[near].max(), jump[~near].max(), jump[near].mean(),
                                             jump[~near].mean()))


def upper_speed(j: np.ndarray) -> np.ndarray:
    return joint_speed(j)[:, UPPER].mean(1)


def silence_ratio(pipe: GesturePipeline, body, gapped_speech: list, speeds: dict, method: str, steps: int,
                  cfg: float, seeds: int) -> float:
    """Upper-body speed inside the gaps (from 1 s after each gap starts) over the speed in the same spans with
    speech, same seeds; `speeds`: (clip, seed) -> upper-body speed with the whole speech."""
    in_gap, with_speech = [], []
    for i, gsp, gaps in gapped_speech:
        for seed in range(seeds):
            res = pipe.generate(gsp, steps=steps, cfg=cfg, seed=seed, method=method, output="raw")
            v0, v1 = speeds[i, seed], upper_speed(body.joints(res.motion.poses, res.motion.trans))
            for a, b in gaps:
                sl = slice(int((a + 1) * 30), int(b * 30))
                in_gap.append(v1[sl].mean())
                with_speech.append(v0[sl].mean())
    return np.mean(in_gap) / np.mean(with_speech) if in_gap else float("nan")


def method_row(pipe: GesturePipeline, body, h: Heldout, speech: list, gapped_speech: list, bank, seams: Seams,
               method: str, steps: int, cfg: float, seeds: int, main_setting: bool) -> tuple[tuple, AmplitudeRow]:
    """One method x steps x CFG over every clip and seed: the table row and the amplitude row (at the main
    setting also the window seams and the speed in silence)."""
    vals, motions = [], []
    speeds = {}                                                      # (clip, seed) -> upper-body speed
    for i, sp in enumerate(speech):
        for seed in range(seeds):
            res = pipe.generate(sp, steps=steps, cfg=cfg, seed=seed, method=method, output="raw")
            j = body.joints(res.motion.poses, res.motion.trans)
            vals.append(clip_stats(j, i, h))
            motions.append(j)
            speeds[i, seed] = upper_speed(j)
            if main_setting:
                seam_stats(j, pipe, method, seams)
    silence = (silence_ratio(pipe, body, gapped_speech, speeds, method, steps, cfg, seeds) if main_setting
               else float("nan"))
    amp = AmplitudeRow(f"{method} {steps} steps CFG {cfg:g}", pooled_stats(motions),
                       replay_novelty(motions, bank, [h.clips[0][3]]))
    v = np.array(vals)
    gains = [f"{g.mean():+.3f} +- {g.std(ddof=1) / np.sqrt(len(g)):.3f} ({(g > 0).sum()}/{len(g)} > 0)"
             for g in (v[:, 2], v[:, 3])]
    return (method, steps, cfg, *v[:, :2].mean(0), *gains, *v[:, 4:].mean(0), silence), amp


def print_report(h: Heldout, seeds: int, rows: list, gt_tests: dict, amp_rows: list, seams: Seams,
                 cfg: float) -> None:
    print(f"held-out clips: {', '.join(c[0] for c in h.clips)}; {seeds} seeds\n")
    print("| method | steps | CFG | BC (own speech) | BC (other speech) | BC gain over shifted speech | "
          "loudness-following gain | upper-body speed (m/s) | jitter (m/s^2) | speed in silence / with speech |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        sil = "-" if np.isnan(r[9]) else f"{r[9]:.2f}"
        print(f"| {r[0]} | {r[1]} | {r[2]} | {r[3]:.3f} | {r[4]:.3f} | {r[5]} | {r[6]} | {r[7]:.3f} | {r[8]:.2f} "
              f"| {sil} |")
    print("\nThe speaker's own motion on the whole real take (63 s), the same tests:\n")
    print("| test | own speech | shifted speech (mean +- sd) | gain | z |")
    print("|---|---|---|---|---|")
    for name, t in gt_tests.items():
        print(f"| {name} | {t.own:.3f} | {t.shifted_mean:.3f} +- {t.shifted_std:.3f} | {t.gain:+.3f} | {t.z:.1f} |")
    print("\nAmplitude (with the transcript; in brackets the ratio to the speaker's whole take):\n")
    print(format_rows(amp_rows, amp_rows[0].stats))
    print("\nWindow seams (frame-to-frame change of joint speed, m/s; +-8 frames around each window border vs the")
    print(f"rest; 8 steps, DDIM 20; CFG {cfg}):\n")
    print("| method | max at borders | max inside | mean at borders | mean inside |")
    print("|---|---|---|---|---|")
    for m, v in seams.items():
        a = np.array(v)
        print(f"| {m} | {a[:, 0].max():.3f} | {a[:, 1].max():.3f} | {a[:, 2].mean():.3f} | {a[:, 3].mean():.3f} |")


def main() -> None:
    args = parse_args()
    if not BEAT2.exists():
        raise SystemExit(f"needs the real BEAT2 sample at {BEAT2}")
    body = load_body_model()
    pipe = GesturePipeline.from_pretrained(args.checkpoints)
    h = load_heldout(body)
    take = h.take
    gt_whole = body.joints(take.motion.poses, take.motion.trans)
    bank = training_bank([h.gt_train])
    amp_rows = [AmplitudeRow("speaker, whole take", pooled_stats([gt_whole]), None),
                AmplitudeRow("speaker, held-out 20 %", pooled_stats([h.clips[0][3]]),
                             replay_novelty([h.clips[0][3]], bank, [h.clips[0][3]]))]
    whole_beats = audio_beats(take.audio)
    gt_tests = {"beat timing (BC)": beat_timing(gt_whole, whole_beats, mean_speed=h.mean_speed),
                "loudness following (correlation)": energy_following(gt_whole, take.audio)}
    gt = clip_stats(h.clips[0][3], 0, h)
    rows = [("ground truth (clip 1 only)", "-", "-", *gt[:2], f"{gt[2]:+.3f}", f"{gt[3]:+.3f}", *gt[4:],
             float("nan"))]
    gapped = [(i, *with_gaps(c[1], c[2])) for i, c in enumerate(h.clips) if len(c[1]) > 20 * 16000]
    gapped_speech = [(i, pipe.prepare_speech(y, 16000, words=w), gaps) for i, y, w, gaps in gapped]
    plan = [(m, s, c) for c in args.cfg for m in ("gesturelsm", "rectified_flow", "ddim") if m in pipe.methods
            for s in args.steps]
    if "ddim" in pipe.methods:
        plan += [("ddim", 20, c) for c in args.cfg]
    speech = [pipe.prepare_speech(c[1], 16000, words=c[2]) for c in h.clips]
    seams: Seams = {}
    for method, steps, cfg in plan:
        main_setting = (steps == 8 or (method == "ddim" and steps == 20)) and cfg == args.cfg[0]
        row, amp = method_row(pipe, body, h, speech, gapped_speech, bank, seams, method, steps, cfg, args.seeds,
                              main_setting)
        rows.append(row)
        amp_rows.append(amp)
    print_report(h, args.seeds, rows, gt_tests, amp_rows, seams, args.cfg[0])


if __name__ == "__main__":
    set_threads(2)
    main()
