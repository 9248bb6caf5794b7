"""Does generated motion respond to speech? Held-out audio, every method at equal steps.

    .venv/bin/python benchmarks/generator_quality.py [--checkpoints assets] [--seeds 3]

Held-out speech: the last 20% of BEAT2 2_scott_0_1_1 (its motion is ground truth) and the audio-only takes
2_scott_0_2_2 and 2_scott_0_3_3, with their TextGrids (all from ../shared). Per method and step count:
- BC: beat consistency with the speech the motion was generated for (METHOD-FACTS definition, speeds
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
- amplitude (metrics.amplitude, issue 16): raised share (a wrist above pelvis + 0.25 m), wrist height p50/p95,
  wrist speed, hand spread, upper-body jerk, pooled over clips x seeds (with the transcript), beside the
  speaker's whole take, and the replay guard (novelty of 1 s windows against the training motion, over the
  speaker's held-out motion's; copies of training clips score ~0). Audio-only: benchmarks/amplitude_stages.py.
Numbers are means over clips and seeds; ground truth is shown where it exists.

The paper's metrics (FGD, BC beside ground truth's, L1 diversity, face error, jitter, foot skating, time) over
methods x steps x CFG are `gesturelsm eval` (gesturelsm/evaluation/); this script keeps the two checks that
command does not make: BC against foreign speech, and window seams.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch

REPO = Path(__file__).resolve().parents[1]
BEAT2 = REPO.parent / "shared" / "data" / "beat2"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--checkpoints", default=None)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--steps", type=int, nargs="+", default=[1, 2, 4, 8])
    ap.add_argument("--cfg", type=float, nargs="+", default=[2.0], help="one or more CFG scales")
    args = ap.parse_args()
    from gesturelsm.body import load_body_model
    from gesturelsm.data.beat2 import Beat2Dataset
    from gesturelsm.evaluation.amplitude import AmplitudeRow, format_rows
    from gesturelsm.metrics.amplitude import pooled_stats, replay_novelty, training_bank
    from gesturelsm.metrics.beat import audio_beats, beat_consistency, joint_speed
    from gesturelsm.metrics.speech_response import beat_timing, energy_following
    from gesturelsm.motion.regions import REGIONS
    from gesturelsm.pipeline import GesturePipeline
    from gesturelsm.align.words import Word

    if not BEAT2.exists():
        raise SystemExit(f"needs the real BEAT2 sample at {BEAT2}")
    body = load_body_model()
    pipe = GesturePipeline.from_pretrained(args.checkpoints)
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
    beats = [audio_beats(c[1]) for c in clips]
    upper = list(REGIONS["upper"].joints)

    def stats(j: np.ndarray, i: int) -> tuple[float, float, float, float, float, float]:
        bc = beat_consistency(j, beats=beats[i], mean_speed=mean_speed)
        other = beats[(i + 1) % len(clips)]
        bc_sh = beat_consistency(j, beats=other, mean_speed=mean_speed)
        gain = beat_timing(j, beats[i], mean_speed=mean_speed).gain
        loud = energy_following(j, clips[i][1]).gain
        sp = joint_speed(j)[:, upper].mean()
        acc = (np.linalg.norm(j[2:] - 2 * j[1:-1] + j[:-2], axis=-1) * 900)[:, upper].mean()
        return bc, bc_sh, gain, loud, sp, acc

    def with_gaps(audio: np.ndarray, words) -> tuple[np.ndarray, list, list[tuple[float, float]]]:
        dur = len(audio) / 16000
        gaps = [(a, a + 4.0) for a in np.arange(6.0, dur - 6.0, 12.0)]
        y = audio.copy()
        for a, b in gaps:
            y[int(a * 16000):int(b * 16000)] = 0
        kept = [w for w in words if not any(w.end > a and w.start < b for a, b in gaps)] if words else words
        return y, kept, gaps

    seams: dict[str, list[tuple[float, float, float, float]]] = {}

    def seam_stats(j: np.ndarray, method: str) -> None:
        """Per-frame max joint speed change (m/s per frame) near window borders vs inside windows."""
        from gesturelsm.generator.sampling import window_layout

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

    rows = []
    gt_whole = body.joints(take.motion.poses, take.motion.trans)
    bank = training_bank([gt_train])
    amp_rows = [AmplitudeRow("speaker, whole take", pooled_stats([gt_whole]), None),
                AmplitudeRow("speaker, held-out 20 %", pooled_stats([clips[0][3]]),
                             replay_novelty([clips[0][3]], bank, [clips[0][3]]))]
    whole_beats = audio_beats(take.audio)
    gt_tests = {"beat timing (BC)": beat_timing(gt_whole, whole_beats, mean_speed=mean_speed),
                "loudness following (correlation)": energy_following(gt_whole, take.audio)}
    gt = stats(clips[0][3], 0)
    rows.append(("ground truth (clip 1 only)", "-", "-", *gt[:2], f"{gt[2]:+.3f}", f"{gt[3]:+.3f}", *gt[4:],
                 float("nan")))
    gapped = [(i, *with_gaps(c[1], c[2])) for i, c in enumerate(clips) if len(c[1]) > 20 * 16000]
    gapped_speech = [(i, pipe.prepare_speech(y, 16000, words=w), gaps) for i, y, w, gaps in gapped]
    plan = [(m, s, c) for c in args.cfg for m in ("gesturelsm", "rectified_flow", "ddim") if m in pipe.methods
            for s in args.steps]
    if "ddim" in pipe.methods:
        plan += [("ddim", 20, c) for c in args.cfg]
    speech = [pipe.prepare_speech(c[1], 16000, words=c[2]) for c in clips]
    def upper_speed(j: np.ndarray) -> np.ndarray:
        return joint_speed(j)[:, upper].mean(1)

    for method, steps, cfg in plan:
        vals, in_gap, with_speech, motions = [], [], [], []
        main_setting = (steps == 8 or (method == "ddim" and steps == 20)) and cfg == args.cfg[0]
        speeds = {}                                                      # (clip, seed) -> upper-body speed
        for i, sp in enumerate(speech):
            for seed in range(args.seeds):
                res = pipe.generate(sp, steps=steps, cfg=cfg, seed=seed, method=method)
                j = body.joints(res.motion.poses, res.motion.trans)
                vals.append(stats(j, i))
                motions.append(j)
                speeds[i, seed] = upper_speed(j)
                if main_setting:
                    seam_stats(j, method)
        if main_setting:
            for i, gsp, gaps in gapped_speech:
                for seed in range(args.seeds):
                    res = pipe.generate(gsp, steps=steps, cfg=cfg, seed=seed, method=method)
                    v0, v1 = speeds[i, seed], upper_speed(body.joints(res.motion.poses, res.motion.trans))
                    for a, b in gaps:
                        sl = slice(int((a + 1) * 30), int(b * 30))
                        in_gap.append(v1[sl].mean())
                        with_speech.append(v0[sl].mean())
        amp_rows.append(AmplitudeRow(f"{method} {steps} steps CFG {cfg:g}", pooled_stats(motions),
                                     replay_novelty(motions, bank, [clips[0][3]])))
        silence = np.mean(in_gap) / np.mean(with_speech) if in_gap else float("nan")
        v = np.array(vals)
        gains = [f"{g.mean():+.3f} +- {g.std(ddof=1) / np.sqrt(len(g)):.3f} ({(g > 0).sum()}/{len(g)} > 0)"
                 for g in (v[:, 2], v[:, 3])]
        rows.append((method, steps, cfg, *v[:, :2].mean(0), *gains, *v[:, 4:].mean(0), silence))
    print(f"held-out clips: {', '.join(c[0] for c in clips)}; {args.seeds} seeds\n")
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
    print(f"rest; 8 steps, DDIM 20; CFG {args.cfg[0]}):\n")
    print("| method | max at borders | max inside | mean at borders | mean inside |")
    print("|---|---|---|---|---|")
    for m, v in seams.items():
        a = np.array(v)
        print(f"| {m} | {a[:, 0].max():.3f} | {a[:, 1].max():.3f} | {a[:, 2].mean():.3f} | {a[:, 3].mean():.3f} |")


if __name__ == "__main__":
    torch.set_num_threads(2)
    main()
