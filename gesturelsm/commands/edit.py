"""`gesturelsm edit`: regenerate body regions of a motion over time ranges, keep the rest, pin key poses
(GesturePipeline.edit; docs/EDITING.md).

    gesturelsm edit take.npz speech.wav --regenerate upper,hands@3.0-6.0 --seed 2 --out take_v2.npz
    gesturelsm edit take.npz speech.wav --regenerate upper@3-6 --regenerate face@10-12 \\
        --keyframe pose.npz:120@4.5 --out take_v3.npz      # frame 120 of pose.npz is the upper body at 4.5 s
    gesturelsm edit take.npz speech.wav --regenerate upper@3-6 --keyframe 40@4.5 --out take_v4.npz
                                                           # frame 40 of take.npz itself, at 4.5 s
"""
from __future__ import annotations

import argparse
import math
import re
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from typing import TYPE_CHECKING

from ..constants import MAX_MOTION_SECONDS, SAMPLE_RATE
from ..errors import UserError
from ..progress import Line
from ..settings import DEFAULT_METHOD, Settings
from ..settings.arguments import (add_language_flag, add_max_seconds_flag, add_post_flags, add_settings_flags,
                                  add_transcribe_flag, cli_settings, input_file, output_file, positive, refuse)

if TYPE_CHECKING:
    from ..motion.sequence import MotionSequence

SPEECH_SLACK = 60.0             # seconds of speech beyond the motion decoded at most (to say how far apart they are)
_FRAME = re.compile(r"[0-9]+")                                 # ASCII digits: str.isdigit() takes "²" and "٣"
_SECONDS = re.compile(r"\s*[-+]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][-+]?[0-9]+)?\s*")   # float() takes "٣.٥"
# REGIONS@START-END; the regions and the numbers are checked by edit_spec, so a negative start or an unknown region
# gets its own message (outside the speech, unknown region) rather than this syntax's
_RANGE = re.compile(r"^\s*([^@]+)@\s*(-?[0-9.]+)\s*-\s*(-?[0-9.]+)\s*$")
say = Line()                    # the progress on stderr (progress.Line: a long motion's windows in a few lines)
NAME = "edit"
HELP = "regenerate body regions of a motion over time ranges, keep the rest"


def add_parser(sub: argparse._SubParsersAction) -> None:
    from ..backends import SPECS
    from ..motion.regions import GENERATED_REGIONS

    g = sub.add_parser(NAME, help=HELP,
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    g.add_argument("motion", help="the motion to edit (BEAT2-layout .npz, e.g. written by `gesturelsm generate`)")
    g.add_argument("audio", help="the speech the motion goes with (wav, flac, mp3, ...)")
    g.add_argument("--regenerate", action="append", default=[], metavar="REGIONS@START-END",
                   help=f"regions ({', '.join(GENERATED_REGIONS)}; comma-separated) and a range in seconds to "
                   "regenerate, e.g. upper,hands@3.0-6.0; repeat for more")
    g.add_argument("--keyframe", action="append", default=[], metavar="POSE.npz:FRAME@TIME",
                   help="pin the upper body (and the hands, where regenerated) at TIME s to frame FRAME of POSE.npz "
                   "(a BEAT2-layout motion; FRAME alone: a frame of MOTION); repeat for more")
    src = g.add_mutually_exclusive_group()
    src.add_argument("--text", help="transcript; word timings are aligned automatically")
    src.add_argument("--textgrid", help="Praat TextGrid with a words tier")
    add_transcribe_flag(src)
    add_language_flag(g)
    g.add_argument("--method", default=DEFAULT_METHOD, choices=list(SPECS),
                   help="a method whose sampler can hold known latents: "
                   + ", ".join(k for k, s in SPECS.items() if s.inpainting) + f" (default: {DEFAULT_METHOD})")
    add_settings_flags(g, steps="one")
    add_max_seconds_flag(g)            # the motion's (so the speech's) length; generate's flag, with the same cap
    g.add_argument("--checkpoints", help="folder with tokenizer/ and generator/ (default: shipped assets)")
    add_post_flags(g)                  # applied to the regenerated motion; the kept motion is the input's
    g.add_argument("--out", required=True, help="output .npz (BEAT2-compatible; .npz is added to a name without it)")
    g.add_argument("--bvh", help="also write the edited motion as BVH")
    g.add_argument("--glb", help="also write the edited motion as an animated GLB")
    g.add_argument("--rig", help="your character (.vrm / .glb / .gltf / .bvh): also writes OUT's stem + the "
                   "character's suffix, the edited motion on it (docs/CHARACTERS.md)")
    g.set_defaults(func=run_edit)


@dataclass(frozen=True)
class Checked:
    """The command's arguments after the checks."""
    settings: Settings
    regenerate: dict[str, list[tuple[float, float]]]
    motion: Path
    audio: Path
    textgrid: Path | None
    rig: Path | None
    out: Path
    bvh: Path | None
    glb: Path | None
    max_seconds: float


def check_arguments(args: argparse.Namespace) -> Checked:
    """Every argument, all problems at once (InputError), before anything is loaded."""
    p: list[str] = []
    settings = cli_settings(args, [args.method], p)
    max_seconds = positive(args.max_seconds, "--max-seconds", p, hi=MAX_MOTION_SECONDS)   # motion_file.py's limit
    try:
        regenerate = parse_regenerate(args.regenerate)
    except UserError as exc:
        p.append(str(exc))
        regenerate = {}
    for item in args.keyframe:
        try:
            keyframe_syntax(item)
        except UserError as exc:
            p.append(str(exc))
    files = [input_file(args.motion, "MOTION", p), input_file(args.audio, "AUDIO", p),
             input_file(args.textgrid, "--textgrid", p) if args.textgrid else None,
             input_file(args.rig, "--rig", p) if args.rig else None, output_file(args.out, "--out", ".npz", p),
             output_file(args.bvh, "--bvh", ".bvh", p) if args.bvh else None,
             output_file(args.glb, "--glb", ".glb", p) if args.glb else None]
    for path, field in ((files[4], "--out"), (files[5], "--bvh"), (files[6], "--glb")):
        if path is not None:
            writable(path, field, p)
    refuse(p)
    return Checked(settings, regenerate, *files, max_seconds)


def writable(path: Path, field: str, problems: list[str]) -> None:
    """A file can be made at `path`: its nearest existing folder takes a new file (tried with a temporary file,
    removed at once: permission bits do not tell for root, /proc or a read-only mount)."""
    folder = path.parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    try:
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".gesturelsm-probe-"):
            pass
    except OSError as exc:
        problems.append(f"{field} {path}: cannot write in {folder} ({exc.strerror or exc}).")


def parse_regenerate(items: list[str]) -> dict[str, list[tuple[float, float]]]:
    """['upper,hands@3-6', 'face@10-12'] -> {'upper': [(3, 6)], 'hands': [(3, 6)], 'face': [(10, 12)]}."""
    out: dict[str, list[tuple[float, float]]] = {}
    for item in items:
        m = _RANGE.match(item)
        if not m:
            raise UserError(f"--regenerate {item!r}: write REGIONS@START-END in seconds, e.g. upper,hands@3.0-6.0")
        try:
            rng = (float(m.group(2)), float(m.group(3)))
        except ValueError:
            raise UserError(f"--regenerate {item!r}: {m.group(2)}-{m.group(3)} is not a range of seconds") from None
        regions = [r.strip().lower() for r in m.group(1).split(",") if r.strip()]
        if not regions:
            from ..motion.regions import GENERATED_REGIONS

            raise UserError(f"--regenerate {item!r}: name the regions before @ ({', '.join(GENERATED_REGIONS)}), "
                            "e.g. upper,hands@3.0-6.0")
        for region in regions:
            out.setdefault(region, []).append(rng)
    if not out:
        raise UserError("nothing to regenerate: give --regenerate REGIONS@START-END, e.g. upper,hands@3.0-6.0")
    return out


def keyframe_syntax(item: str) -> tuple[str | int, float]:
    """'pose.npz:120@4.5' -> ('pose.npz:120', 4.5); '40@6' -> (40, 6.0): frame numbers and times in ASCII digits
    (a UserError otherwise, before anything is loaded)."""
    source, sep, when = item.rpartition("@")
    usage = ("write POSE.npz:FRAME@TIME (or FRAME@TIME for a frame of the motion being edited), e.g. "
             "pose.npz:120@4.5")
    if not sep or not source or not _SECONDS.fullmatch(when):
        raise UserError(f"--keyframe {item!r}: {usage}")
    t = float(when)
    if not math.isfinite(t):
        raise UserError(f"--keyframe {item!r}: {when} is not a time in seconds")
    if _FRAME.fullmatch(source):
        return int(source), t
    if ":" not in source and any(c.isdigit() or c.isnumeric() for c in source):
        raise UserError(f"--keyframe {item!r}: write the frame number in the digits 0-9; {usage}")
    frame = source.rpartition(":")[2]
    if ":" in source and not re.fullmatch(r"\s*-?[0-9]+\s*", frame):
        raise UserError(f"--keyframe {item!r}: the frame number {frame!r} is not written in the digits 0-9; {usage}")
    return source, t


def parse_keyframes(items: list[str], motion: MotionSequence) -> list:
    """['pose.npz:120@4.5', '40@6'] -> keyframes (a bare FRAME is a frame of `motion`)."""
    from ..motion.editing import keyframe

    return [keyframe(t, source, current=motion) for source, t in map(keyframe_syntax, items)]


def run_edit(args: argparse.Namespace) -> int:
    from ..audio import AudioTooLongError, load_audio
    from ..backends import SPECS
    from ..motion.editing import EditError, edit_spec, fit_speech
    from ..motion.sequence import MotionSequence
    from ..retarget import check_usable, load_character

    t0 = time.perf_counter()
    a = check_arguments(args)
    rig = load_character(a.rig) if a.rig else None                  # a bad character stops before the work
    if rig is not None:
        check_usable(rig, draw=False)
    motion = MotionSequence.load(a.motion)
    if motion.duration > a.max_seconds:        # the pipeline's limit on the speech, said here before the models load
        raise EditError(f"{a.motion.name} is {motion.duration:.0f} s long; the limit is {a.max_seconds:g} s: give "
                        f"--max-seconds {math.ceil(motion.duration)} to edit it (at most {MAX_MOTION_SECONDS:g}, "
                        "as for generate)")
    keys = parse_keyframes(args.keyframe, motion)
    edit_spec(a.regenerate, motion.num_frames, keys, SPECS[args.method].regions, args.method)   # before the models
    try:                        # never decode much more speech than an edit of this motion can use
        audio = load_audio(a.audio, max_seconds=motion.duration + SPEECH_SLACK)
    except AudioTooLongError:
        raise EditError(f"{a.audio.name} is more than {SPEECH_SLACK:g} s longer than the motion "
                        f"({motion.duration:.2f} s): give the speech the motion was made from") from None
    fit_speech(audio, motion.num_frames)                             # the speech is the motion's (or nearly)
    words = _words(a, args, motion)
    say(0.0, f"loading the models ({args.method})")
    res = _edited(a, args, motion, audio, keys, words)
    path = res.motion.save(a.out)
    _exports(a, res.motion, path, rig)
    for w in res.warnings:
        print(f"warning: {w}")
    asked = "; ".join(f"{r} {', '.join(f'{x:g}-{y:g} s' for x, y in rr)}" for r, rr in a.regenerate.items())
    print(f"{path}: {asked} regenerated with {args.method}, {res.steps} steps, CFG {res.cfg:g}, seed {res.seed}"
          f"{f', {len(keys)} keyframe(s)' if keys else ''}; {res.text_mode}")
    stages = ", ".join(f"{k} {v:.2f}s" for k, v in res.timings.items())
    print(f"timings: {stages}; total {time.perf_counter() - t0:.1f}s")
    return 0


def _words(a: Checked, args: argparse.Namespace, motion: MotionSequence) -> list | None:
    """--textgrid's words, else (without --text or --no-transcribe) the words kept in the motion file."""
    from ..align.textgrid import read_words
    from ..align.words import Word

    words = read_words(a.textgrid) if a.textgrid else None
    if words is None and args.text is None and not args.no_transcribe and motion.words:
        words = [Word(w, s, e) for w, s, e in motion.words if e > s]     # the words it was made with
        say(0.0, f"using the {len(words)} word timings kept in {a.motion.name} (--text or --textgrid to change them)")
    return words


def _edited(a: Checked, args: argparse.Namespace, motion: MotionSequence, audio, keys: list, words: list | None):
    """The edit the arguments ask for (the models loaded for its method)."""
    from ..backends import checkpoint_sources
    from ..pipeline import GesturePipeline

    pipe = GesturePipeline.from_pretrained(checkpoints=checkpoint_sources(args.checkpoints), methods=[args.method],
                                           max_seconds=a.max_seconds)
    return pipe.edit(motion, audio, a.regenerate, keys, sr=SAMPLE_RATE, words=words, text=args.text,
                     progress=say, settings=a.settings)


def _exports(a: Checked, motion: MotionSequence, path: Path, rig) -> None:
    """--rig, --bvh and --glb of the edited motion."""
    from ..body.model import resolve_body
    from ..export import export_bvh, export_glb
    from ..export.rig import export_rig

    done = [p for p in (rig and export_rig(motion, rig, path, grounding=a.settings.post.grounding),
                        a.bvh and export_bvh(motion, a.bvh, body=resolve_body(None)),
                        a.glb and export_glb(motion, a.glb, body=resolve_body(None))) if p]
    for p in done:
        print(f"wrote {p}")
