"""`gesturelsm generate` (speech -> motion npz): the command line of the pipeline (pipeline.py).

Every argument is checked before any work (the settings' validator, `gesturelsm.settings`); while it works it says
what it does on stderr (reading, transcribing, the windows: progress.Line), shows the words it recognised, and
reports the time both ways: generation only (the paper's AITS convention) and end to end. Without a transcript the
words are recognised window by window while generation already works (gesturelsm.pipelined); the summary says how
much of the transcription was hidden under generation.
"""
from __future__ import annotations

import argparse
import threading
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from ..constants import MAX_MOTION_SECONDS, SAMPLE_RATE
from ..progress import Line
from ..settings import DEFAULT_METHOD, Settings
from ..settings.arguments import (add_language_flag, add_max_seconds_flag, add_post_flags, add_settings_flags,
                                  add_transcribe_flag, cli_settings, input_file, output_file, positive, refuse)

if TYPE_CHECKING:
    from ..pipeline import GenerationResult

say = Line()                    # the progress on stderr (progress.Line: a long speech's windows in a few lines)
NAME = "generate"
HELP = "generate SMPL-X gestures for a speech file"


GENERATE = """`gesturelsm generate`: speech -> one method's motion as a BEAT2-layout npz (SMPL-X, 30 fps).

    gesturelsm generate speech.wav --out out.npz                        # transcribed, GestureLSM, 8 steps
    gesturelsm generate speech.wav --text "hello there" --seed 3 --out out.npz
    gesturelsm generate speech.wav --method ddim --ddim-steps 40 --smoothing off --out ddim.npz
    gesturelsm generate speech.wav --out out.npz --rig avatar.vrm      # also out.vrm: the motion on your character

Then `gesturelsm render out.npz --audio speech.wav --out out.mp4` shows it."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    from ..backends import SPECS

    g = sub.add_parser(NAME, help=HELP, description=GENERATE,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    g.add_argument("audio", help="speech file (wav, flac, mp3, ogg, m4a ...)")
    src = g.add_mutually_exclusive_group()
    src.add_argument("--text", help="transcript; word timings are aligned automatically")
    src.add_argument("--textgrid", help="Praat TextGrid with a words tier")
    add_transcribe_flag(src, help="audio-only: do not transcribe the speech when neither --text nor --textgrid is "
                                  "given")
    add_language_flag(g)
    add_settings_flags(g, steps="one")
    g.add_argument("--method", default=DEFAULT_METHOD, choices=list(SPECS),
                   help="*_authors: the authors' released weights, after `gesturelsm import-reference` (--checkpoints)")
    g.add_argument("--checkpoints", help="folder with tokenizer/ and generator/ (default: shipped assets)")
    add_post_flags(g)
    add_max_seconds_flag(g)
    g.add_argument("--out", required=True, help="output .npz (BEAT2-compatible; .npz is added to a name without it)")
    g.add_argument("--rig", help="your character (.vrm / .glb / .gltf / .bvh): also writes OUT's stem + the "
                   "character's suffix, the motion on it (docs/CHARACTERS.md)")
    g.set_defaults(func=run_generate)


@dataclass(frozen=True)
class Checked:
    """The command's arguments after the checks."""
    settings: Settings
    audio: Path
    textgrid: Path | None
    rig: Path | None
    out: Path
    max_seconds: float


def check_arguments(args: argparse.Namespace) -> Checked:
    """Every argument, all problems at once (InputError), before anything is loaded."""
    p: list[str] = []
    settings = cli_settings(args, [args.method], p)
    max_seconds = positive(args.max_seconds, "--max-seconds", p, hi=MAX_MOTION_SECONDS)   # motion_file.py's limit
    audio = input_file(args.audio, "AUDIO", p)
    textgrid = input_file(args.textgrid, "--textgrid", p) if args.textgrid else None
    rig = input_file(args.rig, "--rig", p) if args.rig else None
    out = output_file(args.out, "--out", ".npz", p)
    refuse(p)
    return Checked(settings, audio, textgrid, rig, out, max_seconds)


def run_generate(args: argparse.Namespace) -> int:
    from ..align.textgrid import read_words
    from ..audio import load_audio
    from ..backends import checkpoint_sources
    from ..export.rig import export_rig
    from ..pipeline import GesturePipeline
    from ..retarget import check_usable, load_character

    t0 = time.perf_counter()
    a = check_arguments(args)
    rig = load_character(a.rig) if a.rig else None               # a bad character stops before the work
    if rig is not None:
        check_usable(rig, draw=False)
    words = read_words(a.textgrid) if a.textgrid else None
    audio = load_audio(a.audio, max_seconds=a.max_seconds)
    say(0.0, f"{a.audio.name}: {len(audio) / SAMPLE_RATE:.1f} s of speech")
    ahead = SpeechAhead(audio, words, args.text, a.settings, a.max_seconds)      # bad speech stops here
    say(0.05, f"loading the models ({args.method})")
    pipe = GesturePipeline.from_pretrained(checkpoints=checkpoint_sources(args.checkpoints), methods=[args.method],
                                           max_seconds=a.max_seconds)
    t1 = time.perf_counter()
    speech = ahead.speech()
    res = pipe.generate(speech, settings=replace(a.settings, methods=(args.method,)),   # finished, keeping its words
                        progress=say)                             # starts while the words are still recognised
    speech = pipe.settled(speech)
    if speech.transcript:
        print(f'recognised: "{speech.transcript}"', flush=True)
    motion = res.motion
    path = motion.save(a.out)
    end_to_end = time.perf_counter() - t1
    if rig is not None:
        print(f"wrote {export_rig(motion, rig, path, grounding=a.settings.post.grounding)}")
    for w in res.warnings:
        print(f"warning: {w}")
    report(res, a.settings, path, end_to_end, t1 - t0, time.perf_counter() - t0)
    return 0


class SpeechAhead:
    """The speech prepared on a thread of its own while the generator loads (`prepare_speech` needs no generator):
    its audio features, and its words typed and timed, given, or recognised window by window (the recogniser's
    words thread keeps going while generation starts, as in `prepare_speech(stream=True)`). `speech()` joins it
    and raises what preparing it raised (bad audio: the InputError that prepare_speech raises)."""

    def __init__(self, audio, words, text: str | None, settings: Settings, max_seconds: float):
        from ..features.text import TextEmbedder
        from ..pipeline import GesturePipeline

        self._out: list = []
        preparer = GesturePipeline({}, max_seconds=max_seconds)     # no methods: it prepares speech only
        preparer.checked_audio(audio, SAMPLE_RATE)                  # silent, too short or too long: said at once
        if words is not None or text or settings.transcribe:         # the text encoder (~3 s) loads from the start,
            threading.Thread(target=lambda: TextEmbedder.shared().available, name="gesturelsm-text-encoder",
                             daemon=True).start()                    # beside the recogniser and the generator

        def prepare() -> None:
            try:
                self._out.append(preparer.prepare_speech(audio, SAMPLE_RATE, words=words, text=text, progress=say,
                                                         transcribe=settings.transcribe, language=settings.language,
                                                         stream=True))
            except BaseException as exc:  # raised where the speech is asked for
                self._out.append(exc)

        self._thread = threading.Thread(target=prepare, name="gesturelsm-speech", daemon=True)
        self._thread.start()

    def speech(self):
        self._thread.join()
        if isinstance(self._out[0], BaseException):
            raise self._out[0]
        return self._out[0]


def report(res: GenerationResult, settings: Settings, path: Path, end_to_end: float, loading: float,
           total: float) -> None:
    post = settings.post
    print(f"{path}: {res.motion.num_frames} frames ({res.motion.duration:.1f} s) with {res.method}, {res.steps} steps, "
          f"CFG {res.cfg:g}, seed {res.seed}, smoothing {post.smoothing}"
          f"{', standing in place' if post.stand_in_place else ''}, grounding {'on' if post.grounding else 'off'}; "
          f"{res.text_mode}")
    from ..pipelined import HIDDEN

    print("timings: " + ", ".join(f"{k} {v:.2f}s" for k, v in res.timings.items() if k != HIDDEN))   # said below
    print(f"real-time factor {res.real_time_factor:.1f}x for generation (features, sampling, decoding: the paper's "
          f"AITS convention), {res.motion.duration / max(end_to_end, 1e-9):.1f}x end to end ({end_to_end:.2f} s "
          f"from the models loaded to the file written: the rest of the speech's words, generation, post-processing, "
          f"writing); loading the models {loading:.1f} s, while the speech was read and prepared; total {total:.1f} s")
    hidden = hidden_transcription(res.timings)
    if hidden:
        print(hidden)


def hidden_transcription(timings: dict[str, float]) -> str | None:
    """"transcription 3.10 s, 2.85 s of it (92 %) hidden under loading the models and generation (...)" for words
    recognised while generated, else None: the speech's words are recognised from the moment it is read (SpeechAhead),
    so all of the transcription but what generation waited for was hidden."""
    from ..pipelined import HIDDEN, WAITING

    if HIDDEN not in timings:
        return None
    tr, waited = timings.get("transcription", 0.0), timings.get(WAITING, 0.0)
    hid = max(0.0, tr - waited)
    return (f"transcription {tr:.2f} s, {hid:.2f} s of it ({100 * hid / max(tr, 1e-9):.0f} %) hidden under loading "
            f"the models and generation (recognised window by window from the moment the speech was read; generation "
            f"waited {waited:.2f} s for words)")
