"""`gesturelsm transcribe AUDIO --out words.TextGrid`: recognise English speech offline and time its words.

The TextGrid has the same layout as `gesturelsm align` writes (one "words" interval tier). Speech that is
not recognised as English (or silence, noise, music) is an error with the reason; nothing is written.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from ..align import read_words
from ..align.cli import output_words
from ..audio import SAMPLE_RATE, load_audio
from ..errors import UserError
from .model import RecognizerUnavailable
from .transcribe import AUDIO_ONLY_NOTE, transcribe


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("transcribe", help="recognise English speech offline, words with times (TextGrid out)",
                       description="Transcribe speech offline (Whisper tiny.en) and time the words (eSpeak NG + DTW).")
    p.add_argument("audio", help="speech file (wav, flac, mp3, ogg, m4a, ...)")
    p.add_argument("--out", type=Path, help="write the words tier here (.TextGrid); default: print the words")
    p.add_argument("--format", choices=("long", "short"), default="long", help="TextGrid text format")
    p.add_argument("--timing", choices=("auto", "dtw", "whisper"), default="auto",
                   help="word times: our aligner on the recognised text, falling back to Whisper's own (auto), "
                        "or only one of them")
    p.add_argument("--reference", type=Path, help="a TextGrid with known word timings: report onset errors")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.out is not None and args.out.suffix.lower() != ".textgrid":
        raise UserError(f"--out must end in .TextGrid (got {args.out.name})")
    reference = read_words(args.reference) if args.reference else None
    audio = load_audio(args.audio, SAMPLE_RATE)
    t0 = time.perf_counter()
    try:
        tr = transcribe(audio, timing=args.timing)
    except RecognizerUnavailable as exc:
        raise UserError(str(exc)) from None
    elapsed = time.perf_counter() - t0
    duration = len(audio) / SAMPLE_RATE
    if not tr.accepted:
        raise UserError(tr.warnings[0].removesuffix(AUDIO_ONLY_NOTE) + " Nothing was written.")
    print(f"{len(tr.words)} words, confidence {tr.confidence:.2f}, word timings {tr.timing_method}, "
          f"{elapsed:.1f} s for {duration:.1f} s of audio")
    print(f"text: {tr.text}")
    for w in tr.warnings:
        print(f"warning: {w}", file=sys.stderr)
    output_words(tr.words, duration, args, reference)
    return 0
