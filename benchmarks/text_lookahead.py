"""What the bounded look-ahead of the text features costs: the same speech, words and seeds with the words
encoded in bounded context (the default: 2-s blocks, 10 s before, 2 s after; features/text.py) and in the context of
the whole transcript (the earlier encoding). Markdown out.

    NUMBA_CACHE_DIR=.venv/numba-cache .venv/bin/python benchmarks/text_lookahead.py [--data DIR] [--seeds 3]

On the held-out BEAT2 take (2_scott_0_1_1, speech + motion, its MFA words) the shipped GestureLSM (8 steps, CFG 2)
generates with each encoding; per encoding: the motion statistics of the page (evaluation/motion_stats.py, means over
seeds) beside the speaker's own motion of the take, the training-free FGD_k and FGD_g against it (metrics/fgd.py;
EMAGE's FGD needs weights these machines cannot reach), and how far the two encodings' motions are apart (mean joint
distance, frame by frame, same seed) against how far two seeds of one encoding are (the scale of "different motion").

    ... text_lookahead.py --timing [--timing-take 2_scott_0_3_3] [--repeats 5]

times the word features instead (one math thread, this process's CPU seconds, medians; the CLI benchmark's 68-s take
with its MFA words): the bounded context as one plain encoder pass per block, the same blocks in batched calls (all at
once: the one-shot path; in pieces at the recognition cuts: the pipelined path), and the whole transcript; with the
largest difference between the plain and the batched vectors.
"""
from __future__ import annotations

from _harness import BEAT2, set_threads

import argparse
import math
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from gesturelsm.align import read_words  # noqa: E402
from gesturelsm.audio import load_audio  # noqa: E402
from gesturelsm.evaluation.motion_stats import (STATISTICS, SpeechContext, joint_positions,  # noqa: E402
                                                 speaker_reference, statistics_of_joints, stats_body)
from gesturelsm.asr.recognition_windows import recognition_cuts  # noqa: E402
from gesturelsm.constants import FPS, SAMPLE_RATE  # noqa: E402
from gesturelsm.features.text import TextEmbedder, WordFeatureStream  # noqa: E402
from gesturelsm.metrics.fgd import GeometricExtractor, KineticExtractor, fgd  # noqa: E402
from gesturelsm.motion import MotionSequence  # noqa: E402
from gesturelsm.pipeline import GesturePipeline  # noqa: E402

TAKE = "2_scott_0_1_1"
SHOWN = ("bc", "beat_gain", "loudness_gain", "raised_share", "height_p95", "wrist_speed", "hand_spread", "jerk",
         "diversity")


class PlainBlocks:
    """An embedder whose `embed_blocks` runs one plain encoder pass per block (unpadded, batch of one)."""

    def __init__(self, emb: TextEmbedder):
        self.emb = emb

    @torch.no_grad()
    def embed_blocks(self, contexts, keeps):
        out = []
        for words, keep in zip(contexts, keeps):
            enc = self.emb._tok(words, is_split_into_words=True, return_tensors="pt", truncation=True, max_length=512)
            h, ids = self.emb._model(**enc).last_hidden_state[0], enc.word_ids()
            out.append(np.stack([h[[i for i, w in enumerate(ids) if w == k]].mean(0).numpy() for k in keep]))
        return out


def timing(data: Path, take: str, repeats: int) -> int:
    """The word features' CPU seconds per way of encoding them (module doc)."""
    wav, tg = data / "wave16k" / f"{take}.wav", data / "textgrid" / f"{take}.TextGrid"
    if not (wav.is_file() and tg.is_file()):
        print(f"no take {take} with speech and TextGrid at {data}", file=sys.stderr)
        return 2
    set_threads(1)
    emb, words, y = TextEmbedder.shared(), read_words(tg), load_audio(wav)
    if not emb.available:
        print(emb.error, file=sys.stderr)
        return 2
    T = len(y) * FPS // SAMPLE_RATE
    finals = [c / SAMPLE_RATE for c in recognition_cuts(y)[1:-1]] + [math.inf]

    def stream(embedder, pieces):
        s, seen = WordFeatureStream(embedder, T), 0
        for until in pieces:
            got = [w for w in words[seen:] if w.start < until]
            seen += len(got)
            s.extend(got, until)
        return s.features

    ways = {"bounded, one plain pass per block": lambda: stream(PlainBlocks(emb), [math.inf]),
            "bounded, batched, all at once (one-shot path)": lambda: stream(emb, [math.inf]),
            f"bounded, batched, in {len(finals)} pieces (pipelined path)": lambda: stream(emb, finals),
            "whole transcript": lambda: emb.frame_features(words, T, context="whole").features}
    cpu: dict[str, list[float]] = {k: [] for k in ways}
    got = {k: f() for k, f in ways.items()}                               # warm, and the vectors compared
    for _ in range(repeats):
        for name, f in ways.items():                                       # interleaved
            c0 = time.process_time()
            f()
            cpu[name].append(time.process_time() - c0)
    print(f"{take}: {len(y) / SAMPLE_RATE:.1f} s, {len(words)} words; one math thread, CPU s, {repeats} interleaved\n")
    print("| word features | CPU s (median) | min |\n|---|---|---|")
    for name, ts in cpu.items():
        print(f"| {name} | {statistics.median(ts):.3f} | {min(ts):.3f} |")
    plain, batched, pieces = list(got.values())[:3]
    print(f"\nlargest |plain - batched|: {np.abs(plain - batched).max():.2e} (vector norms ~"
          f"{np.linalg.norm(plain, axis=1).max():.1f}); batched all at once == in pieces bit for bit: "
          f"{np.array_equal(batched, pieces)}")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=BEAT2)
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--timing", action="store_true", help="time the word features only (module doc)")
    ap.add_argument("--timing-take", default="2_scott_0_3_3")
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    if args.timing:
        return timing(args.data, args.timing_take, args.repeats)
    if not (args.data / "smplxflame_30" / f"{TAKE}.npz").is_file():
        print(f"no BEAT2 take {TAKE} with motion at {args.data}", file=sys.stderr)
        return 2
    set_threads(1)
    body = stats_body()
    pipe = GesturePipeline.from_pretrained(methods=["gesturelsm"])
    y = load_audio(args.data / "wave16k" / f"{TAKE}.wav")
    words = read_words(args.data / "textgrid" / f"{TAKE}.TextGrid")
    bounded = pipe.prepare_speech(y, words=words)
    whole_ft = TextEmbedder.shared().frame_features(words, bounded.num_frames, context="whole")
    inputs = {"bounded (2 s blocks + 2 s ahead)": bounded,
              "whole transcript": replace(bounded, word_features=torch.from_numpy(whole_ft.features))}
    speaker = MotionSequence.load(args.data / "smplxflame_30" / f"{TAKE}.npz")
    real_world, _ = joint_positions(speaker, body)
    ref = speaker_reference()
    ctx = SpeechContext.of(y, mean_speed=ref.mean_speed if ref else None)
    extract = (KineticExtractor(), GeometricExtractor())
    stats, fgds, locs = {}, {}, {}
    for name, speech in inputs.items():
        rows, gen_feats, locs[name] = [], {e.name: [] for e in extract}, []
        for s in range(args.seeds):
            m = pipe.generate(speech, steps=8, cfg=2.0, seed=s, output="raw").motion
            world, local = joint_positions(m, body)
            rows.append(statistics_of_joints(world, local, ctx))
            locs[name].append(local)
            for e in extract:
                gen_feats[e.name].append(e(m, world))
        stats[name] = {k: float(np.nanmean([r[k] for r in rows])) for k in SHOWN}
        fgds[name] = {e.name: fgd([e(speaker, real_world)], gen_feats[e.name]) for e in extract}
    spk = statistics_of_joints(real_world, real_world - np.asarray(speaker.trans, np.float32)[:, None], ctx)
    label = {s.key: s.label for s in STATISTICS}
    names = list(inputs)
    print("| statistic | " + " | ".join(names) + " | speaker (take's motion) |\n" + "|---" * (len(names) + 2) + "|")
    for k in SHOWN:
        print(f"| {label[k]} | " + " | ".join(f"{stats[n][k]:.3f}" for n in names) + f" | {spk[k]:.3f} |")
    for e in extract:
        print(f"| {e.name} vs the take | " + " | ".join(f"{fgds[n][e.name]:.3f}" for n in names) + " | 0 |")
    a, b = locs[names[0]], locs[names[1]]
    apart = np.mean([np.linalg.norm(x - z, axis=-1).mean() for x, z in zip(a, b)])
    seeds = np.mean([np.linalg.norm(a[i] - a[i + 1], axis=-1).mean() for i in range(len(a) - 1)]) if len(a) > 1 else 0
    print(f"\nmean joint distance, same seed, bounded vs whole: {100 * apart:.2f} cm; between seeds (bounded): "
          f"{100 * seeds:.2f} cm")
    return 0


if __name__ == "__main__":
    sys.exit(main())
