"""`gesturelsm align AUDIO --text "..." --out words.TextGrid`: word timings for a transcript, no MFA.

Prints the method, the confidence and any warning (fallbacks are explained, never silent); with
`--reference REF.TextGrid` also the onset error against that file.

`--language` takes the codes every other command takes (auto, en, es, de, ja, ...: languages.CHOICES), read with
that language's eSpeak NG voice (languages.typed_alignment); an eSpeak NG voice (en-gb-x-rp, pt-br, cmn, en-us+f3),
what the flag took before, is still accepted and used as it is.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from ..align.languages import AUTO, CHOICES
from ..errors import UserError

if TYPE_CHECKING:
    from ..align.aligner import AlignConfig

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
    p.add_argument("--language", default=AUTO, metavar="CODE",
                   help=f"the speech's language, as for the other commands: {' '.join(CHOICES)} (default: {AUTO}, "
                        "English unless the text is Chinese or Japanese); the transcript is read with its eSpeak NG "
                        "voice. An eSpeak NG voice (en-gb-x-rp, pt-br, en-us+f3; the File column of "
                        "`espeak-ng --voices`) is used as it is")
    p.add_argument("--reference", type=Path, help="a TextGrid with known word timings: report onset errors")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..align.aligner import align_words
    from ..align.normalize import tokenize
    from ..align.textgrid import read_words
    from ..audio import SAMPLE_RATE, load_audio

    text = _transcript(args, UserError)
    if not tokenize(text):
        raise UserError("the transcript has no words to align (only punctuation or spaces?)")
    if args.out is not None and args.out.suffix.lower() != ".textgrid":
        raise UserError(f"--out must end in .TextGrid (got {args.out.name})")
    reference = read_words(args.reference) if args.reference else None
    config = language_config(args.language, text)
    audio = load_audio(args.audio, SAMPLE_RATE)
    t0 = time.perf_counter()
    result = align_words(audio, text, config)
    elapsed = time.perf_counter() - t0
    duration = len(audio) / SAMPLE_RATE
    print(f"{len(result.words)} words, method {result.method}, confidence {result.confidence:.2f}, "
          f"{elapsed:.1f} s for {duration:.1f} s of audio")
    if result.warning:
        print(f"warning: {result.warning}", file=sys.stderr)
    if not config.voices:
        print(f"hint: `gesturelsm transcribe {args.audio} --language {args.language.strip()}` recognises the words and "
              "times them itself", file=sys.stderr)
    output_words(result.words, duration, args, reference)
    return 0


def language_config(value: str, text: str) -> AlignConfig:
    """How `--language VALUE` reads `text`: a language code (CHOICES) with its eSpeak NG voice, else an eSpeak NG
    voice name as it is (with a +variant or not); UserError naming the codes for anything else. Where eSpeak NG is
    missing a name cannot be checked and is used as given (the aligner then spreads the words and says why)."""
    from ..align import tts
    from ..align.aligner import AlignConfig
    from ..align.languages import typed_alignment

    code = value.strip().lower()
    if code in CHOICES:
        return typed_alignment(code, text)
    base = value.strip().split("+")[0]
    if base:
        try:
            tts.synthesize(["a"], (base,))
        except tts.TTSUnavailable:
            base = "" if tts.available() else base       # eSpeak works but has no such voice
    if not base:
        raise UserError(f"--language {value!r} is neither a language code ({' '.join(CHOICES)}) nor a voice eSpeak NG "
                        "loads (the File column of espeak-ng --voices, e.g. en-gb-x-rp)")
    return AlignConfig.for_language(value.strip())


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
