"""How fast the words of an upload are recognised and timed, A against B in one run (markdown out):

1. Whisper's encoder on one piece with the full 30 s of context (3000 feature frames) and with the English model's
   short context (1500: gesturelsm/asr/model.py), median of --repeat calls each.
2. Recognising the first and the last recognition window of each BEAT2 take (the pieces the short context applies to),
   short context against the full one (`SHORT_CONTEXT` off), interleaved round by round: wall and process CPU seconds.
3. Timing the recognised words of every recognition window of one take with the aligner: its compiled DTW recursion
   (gesturelsm/align/_dtw_kernel.py) against the row-vectorised numpy recursion it replaced (kept as the test oracle in
   tests/align/test_dtw_compiled.py), interleaved: process CPU seconds (eSpeak's worker process is not counted).

    NUMBA_CACHE_DIR=.venv/numba-cache .venv/bin/python benchmarks/recognition_speed.py [--rounds 3] [--take NAME]
"""
from __future__ import annotations

from _harness import BEAT2, REPO, Rows, Stopwatch, cpu_name, json_flag, save_json, set_threads, timed

import argparse
import os
import statistics
import sys

import numpy as np

sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests" / "align"))       # the numpy recursion, the compiled one's oracle

TAKES = ("2_scott_0_1_1", "2_scott_0_2_2", "2_scott_0_3_3")


def encoder(model, y: np.ndarray, repeat: int) -> Rows:
    from gesturelsm.asr.model import FULL_FRAMES, SHORT_FRAMES

    feats = model.feature_extractor(y)[:, :FULL_FRAMES]
    padded = np.zeros((1, feats.shape[0], FULL_FRAMES), np.float32)
    padded[0, :, : feats.shape[1]] = feats
    rows = Rows(["context (feature frames)", "encoder s, median", "CPU s, median"])
    for frames in (FULL_FRAMES, SHORT_FRAMES):
        x = np.ascontiguousarray(padded[..., :frames])
        t = timed(lambda: super(type(model), model).encode(x), repeats=repeat, warmup=1)
        rows.add(frames, f"{t.median:.3f}", f"{t.cpu_median:.3f}")
    return rows


def recognition(pieces: list[np.ndarray], rounds: int) -> Rows:
    import importlib

    from gesturelsm.asr import model

    transcribe = importlib.import_module("gesturelsm.asr.transcribe")
    runs: dict[bool, list[tuple[float, float]]] = {True: [], False: []}
    for _ in range(rounds):
        for short in (True, False):
            model.SHORT_CONTEXT[0] = short
            with Stopwatch() as sw:
                c0 = os.times()
                for p in pieces:
                    transcribe._recognized(p, transcribe.BEAM_SIZE, None, "en")
                c1 = os.times()
            runs[short].append((sw.seconds, (c1.user + c1.system) - (c0.user + c0.system)))
    model.SHORT_CONTEXT[0] = True
    rows = Rows(["context", "wall s (runs)", "median wall s", "median CPU s"])
    for short in (True, False):
        rows.add("short (15 s)" if short else "full (30 s)", ", ".join(f"{w:.2f}" for w, _ in runs[short]),
                 f"{statistics.median(w for w, _ in runs[short]):.2f}",
                 f"{statistics.median(c for _, c in runs[short]):.2f}")
    return rows


def alignment(windows: list[tuple[np.ndarray, str]], rounds: int) -> Rows:
    from test_dtw_compiled import numpy_dtw

    from gesturelsm.align import align_words
    from gesturelsm.align import dtw as D

    compiled = D.dtw
    D.warm()
    cpu: dict[str, list[float]] = {"compiled": [], "numpy": []}
    try:
        for _ in range(rounds):
            for name, f in (("compiled", compiled), ("numpy", numpy_dtw)):
                D.dtw = f
                c0 = os.times()
                for y, text in windows:
                    align_words(y, text)
                c1 = os.times()
                cpu[name].append((c1.user + c1.system) - (c0.user + c0.system))
    finally:
        D.dtw = compiled
    rows = Rows(["DTW recursion", "CPU s (runs)", "median CPU s"])
    for name, runs in cpu.items():
        rows.add(name, ", ".join(f"{c:.2f}" for c in runs), f"{statistics.median(runs):.2f}")
    return rows


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--repeat", type=int, default=5, help="encoder calls per context")
    p.add_argument("--take", default="2_scott_0_3_3", help="the take whose windows are timed by the aligner")
    json_flag(p)
    args = p.parse_args(argv)
    if not (BEAT2 / "wave16k").is_dir():
        print(f"no BEAT2 data at {BEAT2}", file=sys.stderr)
        return 2
    set_threads(1)
    from gesturelsm.asr.model import load_model
    from gesturelsm.asr.recognition_windows import recognition_cuts
    from gesturelsm.asr.transcribe import recognize
    from gesturelsm.audio import load_audio

    print(f"{cpu_name()}, {os.cpu_count()} cores; load average at start {os.getloadavg()[0]:.1f}\n")
    model = load_model()
    audio = {t: load_audio(BEAT2 / "wave16k" / f"{t}.wav") for t in TAKES}
    enc = encoder(model, audio[TAKES[0]][: 9 * 16000], args.repeat)
    print(enc.markdown() + "\n")
    ends = []
    for y in audio.values():
        c = recognition_cuts(y)
        ends += [y[c[0]:c[1]], y[c[-2]:c[-1]]]
    rec = recognition(ends, args.rounds)
    print(f"the first and last recognition windows of the three takes ({len(ends)} pieces, "
          f"{sum(len(e) for e in ends) / 16000:.0f} s):\n" + rec.markdown() + "\n")
    y = audio[args.take]
    cuts = recognition_cuts(y)
    words = [(y[a:b], " ".join(w.text for w in recognize(y[a:b])[0])) for a, b in zip(cuts, cuts[1:])]
    al = alignment(words, args.rounds)
    print(f"timing the recognised words of {args.take}'s {len(words)} windows ({len(y) / 16000:.0f} s):\n"
          + al.markdown())
    print(f"\nload average at the end {os.getloadavg()[0]:.1f}")
    save_json(args.json, {"encoder": enc, "recognition": rec, "alignment": al})
    return 0


if __name__ == "__main__":
    sys.exit(main())
