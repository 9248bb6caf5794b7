"""Evaluation segments (`gesturelsm batch --segments CSV`): the study's stimuli cut from each speech's videos, as the
GENEA Leaderboard cuts its stimuli (its `evaluation_segment_timestamps.csv`).

    file_name,start_seconds,end_seconds,duration_seconds
    2_scott_0_103_103,12.30,22.10,9.80

`file_name` names a speech file of the study (with or without its extension). Each method's whole video of that
speech is made first (generation runs on the whole speech, as a submission's would); then every listed segment is
cut from it (picture and sound, re-encoded so the cut is exact to the frame) into its own blinded video, with its
motion (frames round(30 x start) to round(30 x end)) in key/motion/ and its speech in key/segments/. The study's
trials, its key and its attention checks are over the segments: each segment is a "speech" of the study, named
`<stem>@<start>-<end>.wav`. Speech files with no listed segment are left out of the study (and not rendered).
"""
from __future__ import annotations

import csv
import math
import subprocess
from pathlib import Path

import numpy as np

from ..audio import load_audio
from ..cluster import write_atomic
from ..constants import FPS, SAMPLE_RATE
from ..errors import InputError
from ..export import npz_bytes
from ..motion import MotionSequence
from .naming import blinded_name

SEGMENT_DIR = Path("key") / "segments"
COLUMNS = ("file_name", "start_seconds", "end_seconds")


def read_segments(path: str | Path, audio_files: list[Path]) -> dict[str, list[tuple[float, float]]]:
    """speech file name -> its segments (start, end) in seconds, every problem at once (InputError)."""
    path = Path(path)
    try:
        with open(path, newline="") as fh:
            rows = list(csv.DictReader(fh))
            columns = set(rows[0]) if rows else set()
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise InputError(f"--segments {path}: cannot be read ({exc})") from None
    if not rows or not set(COLUMNS) <= columns:
        raise InputError(f"--segments {path}: needs a header with {', '.join(COLUMNS)} (the leaderboard's "
                         "evaluation_segment_timestamps.csv layout) and one row per segment")
    by_stem = {a.stem: a for a in audio_files} | {a.name: a for a in audio_files}
    out: dict[str, list[tuple[float, float]]] = {}
    problems = []
    for n, row in enumerate(rows, 2):
        name = (row["file_name"] or "").strip()
        audio = by_stem.get(name) or by_stem.get(Path(name).stem)
        try:
            start, end = float(row["start_seconds"]), float(row["end_seconds"])
        except (TypeError, ValueError):
            problems.append(f"--segments {path} line {n}: start_seconds and end_seconds must be numbers")
            continue
        if audio is None:
            problems.append(f"--segments {path} line {n}: no speech file {name!r} in the audio folder")
        elif not (math.isfinite(start) and math.isfinite(end) and 0 <= start < end):
            problems.append(f"--segments {path} line {n}: needs 0 <= start < end (got {start:g} to {end:g})")
        else:
            out.setdefault(audio.name, []).append((start, end))
    refuse = problems[:20] + ([f"... and {len(problems) - 20} more"] if len(problems) > 20 else [])
    if refuse:
        raise InputError("\n".join(refuse))
    return out


def segment_name(audio: Path | str, start: float, end: float) -> str:
    return f"{Path(audio).stem}@{start:.2f}-{end:.2f}.wav"


def check_lengths(segments: dict[str, list[tuple[float, float]]], audio_files: list[Path]) -> None:
    """Every segment within its speech (1/30 s of slack at the end)."""
    problems = []
    for a in audio_files:
        if a.name not in segments:
            continue
        seconds = len(load_audio(a)) / SAMPLE_RATE
        problems += [f"--segments: {a.name} {s:g}-{e:g} s ends after the speech ({seconds:.2f} s)"
                     for s, e in segments[a.name] if e > seconds + 1 / FPS]
    if problems:
        raise InputError("\n".join(problems))


def _cut(src: Path, start: float, seconds: float, dst: Path) -> None:
    import imageio_ffmpeg

    tmp = dst.with_name(dst.stem + ".part.mp4")
    subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", "-i", str(src), "-ss", f"{start:.6f}",
                    "-t", f"{seconds:.6f}", "-c:v", "libx264", "-preset", "veryfast", "-crf", "18", "-pix_fmt",
                    "yuv420p", "-c:a", "aac", "-movflags", "+faststart", str(tmp)], check=True)
    tmp.replace(dst)


def cut_segments(plan, audio_files: list[Path], segments: dict[str, list[tuple[float, float]]], item_type):
    """The study over segments: a plan whose items are the segment videos (made here when missing) and the
    segments' speech files (key/segments/*.wav). `item_type`: batch's StudyItem."""
    import soundfile as sf

    out = plan.out
    (out / SEGMENT_DIR).mkdir(parents=True, exist_ok=True)
    files, items = [], []
    for a in audio_files:
        spans = segments.get(a.name, [])
        speech = load_audio(a) if spans else None
        for start, end in spans:
            name = segment_name(a, start, end)
            wav = out / SEGMENT_DIR / name
            if not wav.exists():
                sf.write(wav, speech[int(round(start * SAMPLE_RATE)):int(round(end * SAMPLE_RATE))], SAMPLE_RATE)
            files.append(wav)
            for it in (i for i in plan.items if i.audio == a.name):
                full = out / "videos" / it.video
                motion = out / "key" / "motion" / Path(it.video).with_suffix(".npz").name
                if not (full.exists() and motion.exists()):
                    continue
                video = blinded_name(plan.salt, name, it.method, {**plan.settings.get(it.method, {}),
                                                                  "segment": [start, end]})
                if not (out / "videos" / video).exists():
                    seq = MotionSequence.load(motion)
                    lo, hi = int(round(start * FPS)), min(int(round(end * FPS)), seq.num_frames)
                    write_atomic(out / "key" / "motion" / Path(video).with_suffix(".npz").name,
                                 npz_bytes(seq.slice(lo, hi)))
                    _cut(full, start, (hi - lo) / FPS, out / "videos" / video)
                items.append(item_type(video, name, it.method))
    return files, items


def total_seconds(segments: dict[str, list[tuple[float, float]]]) -> float:
    return float(np.sum([e - s for spans in segments.values() for s, e in spans]))


__all__ = ["COLUMNS", "SEGMENT_DIR", "check_lengths", "cut_segments", "read_segments", "segment_name",
           "total_seconds"]
