"""Word-onset accuracy of `gesturelsm.align` on real BEAT2 takes against their MFA TextGrids (markdown out).

    NUMBA_CACHE_DIR=.venv/numba-cache .venv/bin/python benchmarks/align_accuracy.py [--data ../shared/data/beat2]
        [--robustness]

The aligner's settings were chosen on takes 2_2 and 3_3 ("tuning"); take 1_1 was kept out ("held out").
Rows: ours (eSpeak NG + DTW), the naive baseline (words evenly over the span from the first to the last
voiced frame) and our fallback (words over the voiced time by length). Speed is seconds of compute per
second of audio on this machine. `--robustness` adds damaged inputs: music before / noise after the speech,
two wrong words inserted every ten words, one word in ten missing from the transcript, a 5 s pause in the
middle, and punctuation / capitals added.
"""
from __future__ import annotations

from _harness import BEAT2

import argparse
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from gesturelsm.align import Word, align_words, read_words  # noqa: E402
from gesturelsm.align.aligner import even_onsets  # noqa: E402
from gesturelsm.align.features import frame_time, voice_activity  # noqa: E402
from gesturelsm.align.metrics import OnsetStats, onset_errors_ms, onset_stats  # noqa: E402
from gesturelsm.audio import load_audio  # noqa: E402

SR = 16_000
TAKES = (("2_scott_0_1_1", "held out"), ("2_scott_0_2_2", "tuning"), ("2_scott_0_3_3", "tuning"))


def naive(words: list[str], audio: np.ndarray) -> list[Word]:
    """Words evenly over [first voiced frame, last voiced frame]."""
    voiced = np.nonzero(voice_activity(audio).voiced)[0]
    t0, t1 = frame_time(voiced[0]), frame_time(voiced[-1] + 1)
    starts = np.linspace(t0, t1, len(words), endpoint=False)
    return [Word(w, float(s), float(s + (t1 - t0) / len(words))) for w, s in zip(words, starts)]


def fallback(words: list[str], audio: np.ndarray) -> list[Word]:
    starts = even_onsets(words, voice_activity(audio), len(audio) / SR)
    return [Word(w, float(s), float(s)) for w, s in zip(words, starts)]


def row(label: str, take: str, split: str, s: OnsetStats, speed: str = "") -> str:
    return (f"| {take} ({split}) | {label} | {s.n} | {s.mean_ms:.0f} | {s.median_ms:.0f} | {s.p90_ms:.0f} | "
            f"{100 * s.within_100ms:.0f} % | {speed} |")


def accuracy(data: Path) -> None:
    print("| take | method | words | mean ms | median ms | p90 ms | within 100 ms | s per s audio |")
    print("|---|---|---|---|---|---|---|---|")
    pooled: dict[str, list[np.ndarray]] = {"ours": [], "naive": [], "fallback": []}
    for take, split in TAKES:
        ref = read_words(data / "textgrid" / f"{take}.TextGrid")
        audio = load_audio(data / "wave16k" / f"{take}.wav")
        text = " ".join(w.text for w in ref)
        t0 = time.perf_counter()
        result = align_words(audio, text)
        speed = (time.perf_counter() - t0) / (len(audio) / SR)
        errs = {"ours": onset_errors_ms(result.words, ref),
                "naive": onset_errors_ms(naive([w.text for w in ref], audio), ref),
                "fallback": onset_errors_ms(fallback([w.text for w in ref], audio), ref)}
        for name, e in errs.items():
            label = {"ours": f"ours ({result.method}, confidence {result.confidence:.2f})",
                     "naive": "naive: evenly over the speech span", "fallback": "fallback: voiced time by length"}[name]
            print(row(label, take, split, onset_stats(e), f"{speed:.3f}" if name == "ours" else ""))
            if split == "tuning":
                pooled[name].append(e)
    for name, es in pooled.items():
        print(row(name, "2_2 + 3_3", "tuning, pooled", onset_stats(np.concatenate(es))))


def robustness(data: Path) -> None:
    rng = np.random.default_rng(0)
    print("\n| take | input | words | mean ms | p90 ms | within 100 ms | method | confidence |")
    print("|---|---|---|---|---|---|---|---|")
    for take, split in TAKES:
        ref = read_words(data / "textgrid" / f"{take}.TextGrid")
        audio = load_audio(data / "wave16k" / f"{take}.wav")
        for name, (y, text, truth) in damaged(ref, audio, rng).items():
            r = align_words(y, text)
            s = onset_stats(onset_errors_ms(r.words, truth))
            print(f"| {take} ({split}) | {name} | {s.n} | {s.mean_ms:.0f} | {s.p90_ms:.0f} | "
                  f"{100 * s.within_100ms:.0f} % | {r.method} | {r.confidence:.2f} |")


def damaged(ref: list[Word], y: np.ndarray, rng: np.random.Generator) -> dict[str, tuple]:
    words = [w.text for w in ref]
    t = np.arange(3 * SR) / SR
    chord = sum(np.sin(2 * np.pi * f * h * t + k) / h for k, f in enumerate((220, 277, 330, 440)) for h in (1, 2, 3))
    drums = (np.sin(2 * np.pi * 2 * t) > 0.95) * rng.normal(size=len(t))
    music = (0.012 * chord + 0.05 * drums).astype(np.float32)
    noise = (0.01 * rng.normal(size=2 * SR)).astype(np.float32)
    out = {"clean": (y, " ".join(words), ref),
           "3 s music before, 2 s noise after": (np.concatenate([music, y, noise]), " ".join(words), _shift(ref, 0, 3))}
    extra = []
    for k, w in enumerate(words):
        extra.append(w)
        if k % 10 == 5:
            extra += ["purple", "elephant"]
    out["2 words not spoken, every 10"] = (y, " ".join(extra), ref)
    kept = [w for k, w in enumerate(ref) if k % 10 != 3]
    out["1 word in 10 missing"] = (y, " ".join(w.text for w in kept), kept)
    gaps = [(a.end, b.start) for a, b in zip(ref, ref[1:]) if b.start - a.end > 0.1]
    g0, g1 = min(gaps, key=lambda g: abs(g[0] - len(y) / SR / 2))
    cut = int((g0 + g1) / 2 * SR)
    quiet = y[int(g0 * SR) + 80:int(g1 * SR) - 80]
    pause = (quiet.std() * rng.normal(size=5 * SR)).astype(np.float32)
    out["5 s pause inserted"] = (np.concatenate([y[:cut], pause, y[cut:]]), " ".join(words), _shift(ref, cut / SR, 5))
    styled = [(w.capitalize() if k % 7 == 0 else w) + ("," if k % 5 == 4 else "") + ("." if k % 13 == 12 else "")
              for k, w in enumerate(words)]
    out["punctuation and capitals"] = (y, " ".join(styled), ref)
    return out


def _shift(words: list[Word], at: float, dt: float) -> list[Word]:
    return [Word(w.text, w.start + dt, w.end + dt) if w.start >= at else w for w in words]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=BEAT2)
    ap.add_argument("--robustness", action="store_true", help="also run the damaged-input table")
    args = ap.parse_args()
    if not (args.data / "textgrid").is_dir():
        print(f"no BEAT2 data at {args.data} (expected textgrid/ and wave16k/)", file=sys.stderr)
        return 2
    accuracy(args.data)
    if args.robustness:
        robustness(args.data)
    return 0


if __name__ == "__main__":
    sys.exit(main())
