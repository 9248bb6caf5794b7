"""How long automatic transcription takes to refuse non-speech: `transcribe` (one greedy pass, loops rejected)
against Whisper's own temperature fallback on the same audio (markdown table out).

    .venv/bin/python benchmarks/transcribe_nonspeech.py [--seconds 30]

Audio: a steady four-note chord and two alternating tones (synthetic, --seconds long), white noise, and the real
BEAT2 take 2_scott_0_2_2 from ../shared when present (speech: both paths must give the same words). One run each,
wall seconds; the machine may be shared, so compare rows of one run.
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

from gesturelsm.asr.model import load_model  # noqa: E402
from gesturelsm.asr.transcribe import FALLBACK_TEMPERATURES, recognize  # noqa: E402
from gesturelsm.audio import load_audio  # noqa: E402
from gesturelsm.constants import SAMPLE_RATE as SR  # noqa: E402

TAKE = BEAT2 / "wave16k" / "2_scott_0_2_2.wav"


def sounds(seconds: float) -> dict[str, np.ndarray]:
    t = np.arange(int(seconds * SR)) / SR
    out = {"chord": sum(0.1 * np.sin(2 * np.pi * f * t * (1 + 0.01 * np.sin(np.pi * t)))
                        for f in (261.6, 329.6, 392.0, 523.3)),
           "tones": 0.3 * np.sin(2 * np.pi * 220 * t) * (np.sin(4 * np.pi * t) > 0) + 0.2 * np.sin(2 * np.pi * 330 * t),
           "white noise": 0.1 * np.random.default_rng(0).standard_normal(len(t))}
    if TAKE.exists():
        out["BEAT2 speech"] = load_audio(TAKE)
    return {k: np.asarray(v, np.float32) for k, v in out.items()}


def whisper_fallback(y: np.ndarray) -> list[str]:
    segments, _ = load_model().transcribe(y, language="en", beam_size=1, word_timestamps=True,
                                          condition_on_previous_text=False, temperature=list(FALLBACK_TEMPERATURES))
    return [w.word.strip() for s in segments for w in (s.words or []) if w.word.strip()]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=30.0)
    args = ap.parse_args()
    load_model()
    print("| audio | seconds | Whisper's fallback: wall s, words | transcribe's rule: wall s, words | verdict "
          "| same words |")
    print("|---|---|---|---|---|---|")
    for name, y in sounds(args.seconds).items():
        a = time.perf_counter()
        old = whisper_fallback(y)
        t_old = time.perf_counter() - a
        a = time.perf_counter()
        words, _, details = recognize(y)
        t_new = time.perf_counter() - a
        verdict = "repeated phrase" if details.get("repeated_phrase") else ("words" if words else "no words")
        print(f"| {name} | {len(y) / SR:.0f} | {t_old:.2f}, {len(old)} | {t_new:.2f}, {len(words)} | {verdict} "
              f"| {old == [w.text for w in words]} |")


if __name__ == "__main__":
    main()
