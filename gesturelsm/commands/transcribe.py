"""`gesturelsm transcribe AUDIO [--language auto|en|ja|...] --out words.TextGrid`: recognise speech offline and time
its words.

The TextGrid has the same layout as `gesturelsm align` writes (one "words" interval tier). Speech that is not
recognised (silence, noise, music, a language neither recogniser is sure of) is an error with the reason; nothing is
written.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from ..asr.languages import AUTO, CHOICES, LANGUAGES
from ..errors import UserError
from .align import output_words

NAME = "transcribe"
HELP = "recognise speech offline, words with times (TextGrid out)"


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(NAME, help=HELP,
                       description="Transcribe speech offline and time the words: English with Whisper tiny.en and "
                                   "our aligner (eSpeak NG + DTW); other languages with Whisper base and its own word "
                                   "times (docs/TRANSCRIPTION.md).")
    p.add_argument("audio", help="speech file (wav, flac, mp3, ogg, m4a, ...)")
    p.add_argument("--out", type=Path, help="write the words tier here (.TextGrid); default: print the words")
    p.add_argument("--format", choices=("long", "short"), default="long", help="TextGrid text format")
    p.add_argument("--timing", choices=("auto", "dtw", "whisper"), default="auto",
                   help="word times: our aligner on the recognised text, falling back to Whisper's own (auto), "
                        "or only one of them")
    p.add_argument("--language", default=AUTO, metavar="CODE",
                   help="the speech's language: auto (English first, else the language the multilingual recogniser "
                        f"identifies) or one of {' '.join(LANGUAGES)} (default: {AUTO})")
    p.add_argument("--reference", type=Path, help="a TextGrid with known word timings: report onset errors")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..align import read_words
    from ..asr.model import RecognizerUnavailable
    from ..asr.source import language_said
    from ..asr.transcribe import AUDIO_ONLY_NOTE, transcribe
    from ..audio import SAMPLE_RATE, load_audio

    if args.out is not None and args.out.suffix.lower() != ".textgrid":
        raise UserError(f"--out must end in .TextGrid (got {args.out.name})")
    language = args.language.strip().lower()
    if language not in CHOICES:
        raise UserError(f"--language must be auto or a language code such as en, ja, zh, es, de, fr (got "
                        f"{args.language!r}; the list: gesturelsm transcribe --help)")
    reference = read_words(args.reference) if args.reference else None
    audio = load_audio(args.audio, SAMPLE_RATE)
    t0 = time.perf_counter()
    try:
        tr = transcribe(audio, timing=args.timing, language=language)
    except RecognizerUnavailable as exc:
        raise UserError(str(exc)) from None
    elapsed = time.perf_counter() - t0
    duration = len(audio) / SAMPLE_RATE
    if not tr.accepted:
        raise UserError(tr.warnings[0].removesuffix(AUDIO_ONLY_NOTE) + " Nothing was written.")
    print(f"{len(tr.words)} words{language_said(tr)}, confidence {tr.confidence:.2f}, word timings {tr.timing_method}, "
          f"{elapsed:.1f} s for {duration:.1f} s of audio")
    print(f"text: {tr.text}")
    for w in tr.warnings:
        print(f"warning: {w}", file=sys.stderr)
    output_words(tr.words, duration, args, reference)
    return 0
