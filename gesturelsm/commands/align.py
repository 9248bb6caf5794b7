"""`gesturelsm align AUDIO --text "..." --out words.TextGrid`: word timings for a transcript, no MFA.

Prints the method, the confidence and any warning (fallbacks are explained, never silent); with
`--reference REF.TextGrid` also the onset error against that file.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from ..errors import UserError

NAME = "align"
HELP = "word timings for a transcript (TextGrid out), no forced aligner needed"


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(NAME, help=HELP,
                       description="Align a transcript to speech offline (eSpeak NG + DTW) and write a TextGrid.")
    p.add_argument("audio", help="speech file (wav, flac, mp3, ogg, m4a, ...)")
    src = p.add_mutually_exclusive_group()
    src.add_argument("--text", help="the transcript (punctuation, numbers and casing are fine)")
    src.add_argument("--text-file", type=Path, help="read the transcript from this UTF-8 text file")
    p.add_argument("--out", type=Path, help="write the words tier here (.TextGrid); default: print the words")
    p.add_argument("--format", choices=("long", "short"), default="long", help="TextGrid text format")
    p.add_argument("--language", default="en-us",
                   help="eSpeak NG language/voice of the speech (default en-us; see `espeak-ng --voices`)")
    p.add_argument("--reference", type=Path, help="a TextGrid with known word timings: report onset errors")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..align.aligner import AlignConfig, align_words
    from ..align.normalize import tokenize
    from ..align.textgrid import read_words
    from ..audio import SAMPLE_RATE, load_audio

    text = _transcript(args, UserError)
    if not tokenize(text):
        raise UserError("the transcript has no words to align (only punctuation or spaces?)")
    if args.out is not None and args.out.suffix.lower() != ".textgrid":
        raise UserError(f"--out must end in .TextGrid (got {args.out.name})")
    reference = read_words(args.reference) if args.reference else None
    audio = load_audio(args.audio, SAMPLE_RATE)
    t0 = time.perf_counter()
    result = align_words(audio, text, AlignConfig.for_language(args.language))
    elapsed = time.perf_counter() - t0
    duration = len(audio) / SAMPLE_RATE
    print(f"{len(result.words)} words, method {result.method}, confidence {result.confidence:.2f}, "
          f"{elapsed:.1f} s for {duration:.1f} s of audio")
    if result.warning:
        print(f"warning: {result.warning}", file=sys.stderr)
    output_words(result.words, duration, args, reference)
    return 0


def output_words(words: list, duration: float, args: argparse.Namespace, reference: list | None) -> None:
    """Write the words tier to `args.out` (a TextGrid in `args.format`) or print one word a line; with a
    `reference` (words with known timings) print the onset errors. Shared by `align` and `transcribe`."""
    from ..align.metrics import onset_errors_ms, onset_stats
    from ..align.textgrid import write_textgrid

    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        write_textgrid(args.out, words, duration, args.format)
        print(f"wrote {args.out}")
    else:
        for w in words:
            print(f"{w.start:8.3f} {w.end:8.3f}  {w.text}")
    if reference is not None:
        s = onset_stats(onset_errors_ms(words, reference))
        print(f"onset error vs {args.reference.name}: {s.n} words, mean {s.mean_ms:.0f} ms, "
              f"90th percentile {s.p90_ms:.0f} ms, {100 * s.within_100ms:.0f} % within 100 ms")


def _transcript(args: argparse.Namespace, error: type[Exception]) -> str:
    if args.text is not None:
        return args.text
    if args.text_file is not None:
        try:
            return args.text_file.read_text(encoding="utf-8-sig")
        except FileNotFoundError:
            raise error(f"transcript file not found: {args.text_file}") from None
        except UnicodeDecodeError:
            raise error(f"{args.text_file} is not UTF-8 text") from None
    raise error("give the transcript with --text \"...\" or --text-file FILE")
