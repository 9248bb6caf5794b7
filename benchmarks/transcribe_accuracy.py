"""Automatic transcription (gesturelsm.asr) on the real BEAT2 takes against their MFA TextGrids (markdown out).

    NUMBA_CACHE_DIR=.venv/numba-cache .venv/bin/python benchmarks/transcribe_accuracy.py [--data DIR] [--beam-size 1]
    ... benchmarks/transcribe_accuracy.py --windowed     # recognition windows (what `transcribe` runs) vs whole

--windowed: word recall of the English model run on the whole take at once (Whisper's own 30-s windows) against
recognition window by window as `transcribe` and the pipelined generation run it (asr/recognition_windows.py: a short
first window, the rest ~24 s, cut in pauses), each window timed by the aligner on its own; recognition + alignment
seconds of each, and the words' onset error against MFA. --full-context: every piece encoded with Whisper's 30 s of
context (without the English model's short context for short pieces), to compare.

Per take: word recovery (recognised words paired in order with the MFA words by spoken form / MFA words),
word-onset error against MFA (mean, p90, share within 100 ms) for each timing option ("whisper": Whisper's
own word times; "dtw": our eSpeak+DTW aligner on the recognised text; "auto": what `transcribe` uses, dtw
unless the aligner falls back), seconds of compute per minute of speech (wall clock and process CPU time,
recognition alone and with alignment) and the memory of recognition, measured in a fresh subprocess (resident size
before and after loading the model, peak while transcribing).
The machine is shared: wall-clock seconds include waiting for the CPU; CPU seconds do not.
"""
from __future__ import annotations

from _harness import BEAT2

import argparse
import difflib
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from gesturelsm.align import Word, align_words, read_words  # noqa: E402
from gesturelsm.align.metrics import onset_errors_ms, onset_stats  # noqa: E402
from gesturelsm.align.normalize import speak  # noqa: E402
from gesturelsm.asr.model import SHORT_CONTEXT  # noqa: E402
from gesturelsm.asr.transcribe import BEAM_SIZE, MIN_AVG_LOGPROB, english_pieces, recognize  # noqa: E402
from gesturelsm.asr.recognition_windows import recognition_cuts  # noqa: E402
from gesturelsm.audio import load_audio  # noqa: E402

SR = 16_000
TAKES = ("2_scott_0_1_1", "2_scott_0_2_2", "2_scott_0_3_3")


def recovered(pred: list[Word], ref: list[Word]) -> int:
    """How many reference words are paired, in order and by spoken form, with a recognised word."""
    sm = difflib.SequenceMatcher(a=[speak(w.text) for w in pred], b=[speak(w.text) for w in ref], autojunk=False)
    return sum(b.size for b in sm.get_matching_blocks())


def accuracy(data: Path, beam_size: int) -> list[str]:
    rows = ["| take | MFA words | recovered | timing | mean ms | p90 ms | within 100 ms | s/min recognise (wall, CPU) "
            "| s/min + align (wall) | accepted (avg log-prob) |", "|---|---|---|---|---|---|---|---|---|---|"]
    recognize(np.zeros(SR, np.float32))  # load the model outside the timings
    pooled: dict[str, list[np.ndarray]] = {"whisper": [], "dtw": [], "auto": []}
    tot = [0, 0]
    for take in TAKES:
        ref = read_words(data / "textgrid" / f"{take}.TextGrid")
        y = load_audio(data / "wave16k" / f"{take}.wav")
        minutes = len(y) / SR / 60
        t0, c0 = time.perf_counter(), time.process_time()
        words, avg, _ = recognize(y, beam_size)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        t1 = time.perf_counter()
        res = align_words(y, " ".join(w.text for w in words))
        align_s = time.perf_counter() - t1
        options = {"whisper": words, "dtw": res.words, "auto": res.words if res.method == "dtw" else words}
        n = recovered(words, ref)
        tot[0], tot[1] = tot[0] + n, tot[1] + len(ref)
        for name, ws in options.items():
            e = onset_errors_ms(ws, ref)
            pooled[name].append(e)
            s = onset_stats(e)
            lead = (f"| {take} | {len(ref)} | {n} ({100 * n / len(ref):.0f} %) | {name} |" if name == "whisper"
                    else f"| | | | {name}{' (' + res.method + ')' if name == 'dtw' else ''} |")
            tail = (f" {wall / minutes:.1f}, {cpu / minutes:.1f} | {(wall + align_s) / minutes:.1f} | "
                    f"{'yes' if avg >= MIN_AVG_LOGPROB else 'no'} ({avg:.2f}) |" if name == "whisper" else " | | |")
            rows.append(f"{lead} {s.mean_ms:.0f} | {s.p90_ms:.0f} | {100 * s.within_100ms:.0f} % |{tail}")
    for name, es in pooled.items():
        s = onset_stats(np.concatenate(es))
        lead = (f"| all three | {tot[1]} | {tot[0]} ({100 * tot[0] / tot[1]:.1f} %) |" if name == "whisper"
                else "| | | |")
        rows.append(f"{lead} {name} | {s.mean_ms:.0f} | {s.p90_ms:.0f} | {100 * s.within_100ms:.0f} % | | | |")
    return rows


def windowed(data: Path, beam_size: int) -> list[str]:
    """Whole-take recognition (then alignment of the whole text) against window-by-window recognition and alignment."""
    rows = ["| take | MFA words | windows (s) | recovered, whole | recovered, windowed | s whole (recognise + align) "
            "| s windowed | onset mean ms whole / windowed |", "|---|---|---|---|---|---|---|---|"]
    recognize(np.zeros(SR, np.float32))
    tot = [0, 0, 0]
    for take in TAKES:
        ref = read_words(data / "textgrid" / f"{take}.TextGrid")
        y = load_audio(data / "wave16k" / f"{take}.wav")
        t0 = time.perf_counter()
        words, _, _ = recognize(y, beam_size)
        whole = align_words(y, " ".join(w.text for w in words)).words
        t1 = time.perf_counter()
        pieces = list(english_pieces(y, "auto", beam_size))
        t2 = time.perf_counter()
        win = [w for p in pieces for w in p.words]
        a, b = recovered(whole, ref), recovered(win, ref)
        tot = [tot[0] + len(ref), tot[1] + a, tot[2] + b]
        cuts = ", ".join(f"{c / SR:.1f}" for c in recognition_cuts(y)[1:-1])
        ea, eb = onset_stats(onset_errors_ms(whole, ref)), onset_stats(onset_errors_ms(win, ref))
        rows.append(f"| {take} | {len(ref)} | cut at {cuts} | {a} ({100 * a / len(ref):.1f} %) | {b} "
                    f"({100 * b / len(ref):.1f} %) | {t1 - t0:.1f} | {t2 - t1:.1f} | {ea.mean_ms:.0f} / "
                    f"{eb.mean_ms:.0f} |")
    rows.append(f"| all three | {tot[0]} | | {tot[1]} ({100 * tot[1] / tot[0]:.1f} %) | {tot[2]} "
                f"({100 * tot[2] / tot[0]:.1f} %) | | | |")
    return rows


def _status_mb(key: str) -> float:
    """VmRSS (resident now) or VmHWM (peak resident since start or the last reset) of this process, MB."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def memory_child(data: Path) -> None:
    """Run in a fresh interpreter: resident memory before / after loading the model and peak while transcribing
    (the peak is reset after loading via /proc/self/clear_refs, Linux), printed as JSON."""
    audio = [load_audio(data / "wave16k" / f"{t}.wav") for t in TAKES]
    base = _status_mb("VmRSS")
    from gesturelsm.asr.model import load_model

    load_model()
    loaded = _status_mb("VmRSS")
    Path("/proc/self/clear_refs").write_text("5")   # reset the peak to the current resident size
    for y in audio:
        recognize(y)
    print(json.dumps({"baseline": base, "model loaded": loaded, "peak transcribing": _status_mb("VmHWM"),
                      "ru_maxrss": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}))


def memory(data: Path) -> str:
    out = subprocess.run([sys.executable, __file__, "--data", str(data), "--memory-child"], capture_output=True,
                         text=True, check=True)
    m = json.loads(out.stdout.strip().splitlines()[-1])
    return (f"Resident memory of recognition (fresh process, /proc/self/status): {m['baseline']:.0f} MB with the "
            f"package and audio loaded; {m['model loaded']:.0f} MB with the model loaded "
            f"(+{m['model loaded'] - m['baseline']:.0f} MB); peak {m['peak transcribing']:.0f} MB while transcribing "
            f"the three takes (+{m['peak transcribing'] - m['baseline']:.0f} MB over the baseline).")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=BEAT2)
    ap.add_argument("--beam-size", type=int, default=BEAM_SIZE,
                    help=f"Whisper's beam (default {BEAM_SIZE}, as shipped)")
    ap.add_argument("--windowed", action="store_true", help="only: whole-take against window-by-window recognition")
    ap.add_argument("--full-context", action="store_true", help="encode every piece with Whisper's full 30 s of "
                    "context (the English model's short context for short pieces off: gesturelsm/asr/model.py)")
    ap.add_argument("--memory-child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.full_context:
        SHORT_CONTEXT[0] = False
    if not (args.data / "textgrid").is_dir():
        print(f"no BEAT2 data at {args.data} (expected textgrid/ and wave16k/)", file=sys.stderr)
        return 2
    if args.memory_child:
        memory_child(args.data)
        return 0
    if args.windowed:
        print("\n".join(windowed(args.data, args.beam_size)))
        return 0
    print("\n".join(accuracy(args.data, args.beam_size)))
    print("\n" + memory(args.data))
    return 0


if __name__ == "__main__":
    sys.exit(main())
