"""One study video as a unit of work: generate one method's motion for one speech, render it, and hand back the
files, for `gesturelsm batch` in this process or as a task on a Ray cluster (`--cluster`, gesturelsm.cluster).

The unit's inputs carry everything it needs (the speech's samples, its transcript, the settings, the ground-truth
take's two files when asked for); the checkpoints, body model and character go to each worker once (cluster.Files).
The result comes back as bytes and the driver writes them, whole (`write_video`):

    videos/v_XXXXXXXXXX.mp4           the video, written last: a video that exists is finished
    videos/v_XXXXXXXXXX.vrm / .glb    with --rig: the motion on the character
    key/motion/v_XXXXXXXXXX.npz       the motion behind the video (BEAT2 layout), to measure exactly what raters saw

A unit's motion is the same bytes wherever it runs on the same kind of CPU: it generates with one math thread (a Ray
worker with one CPU has one; more threads sum in another order) and PyTorch's default kernels (the fast paths of
gesturelsm.kernels are chosen by timing each process, and sum in another order too), and the npz carries no time of
writing (export.npz_bytes).
"""
from __future__ import annotations

import contextlib
import hashlib
import os
import tempfile
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Iterator

import numpy as np
import torch

from ..align import read_result
from ..audio import load_audio
from ..body import load_body_model
from ..cluster import Connection, Files, Job, ProgressLine, RunReport, Unit, run_units, write_atomic
from ..data.lookup import find_beat2_take
from ..export import npz_bytes
from ..export.rig import export_rig_glb
from ..pipeline import GROUND_TRUTH, GesturePipeline, Plan
from ..render import render_video
from ..retarget import load_character

MOTION_DIR = Path("key") / "motion"
KERNELS = "GESTURELSM_KERNELS"                # gesturelsm.kernels reads it at every choice


@dataclass(frozen=True)
class VideoSpec:
    """What every video of a study shares; built once per process (`build`)."""
    checkpoints: tuple[Files, ...]           # what `checkpoint_sources` gave (the package's own assets stay home)
    methods: tuple[str, ...]                 # generators to load (empty: ground truth only)
    body: Files | None                       # the SMPL-X body model file (None: the built-in mannequin)
    rig: Files | None                        # the character (.vrm / .glb), or None
    size: int                                # pixels, square


@dataclass(frozen=True)
class VideoUnit:
    video: str                               # file name under videos/
    audio_name: str                          # the speech file's name (a ground-truth take is recognised by it)
    method: str
    plan: Plan                               # that one method with the study's settings; beat2 set by `take`
    audio: np.ndarray = field(repr=False)    # (N,) 16 kHz mono
    words: tuple | None = None               # from NAME.TextGrid
    text: str | None = None                  # from NAME.txt
    take: Files | None = None                # ground truth: the take's motion and speech, in BEAT2 layout
    render: bool = True                      # False: the video exists, only its motion is missing


@dataclass(frozen=True)
class VideoFiles:
    video: bytes | None                      # None when render was False, or nothing to show (note says why)
    motion: bytes | None                     # the BEAT2 npz
    rig: tuple[str, bytes] | None = None     # (suffix, bytes) of the motion on the character
    note: str | None = None


@dataclass
class Built:
    pipeline: GesturePipeline
    body: object
    rig: object
    size: int
    speech: dict = field(default_factory=dict)   # the last prepared speech by content: a speech's methods share it


def build(spec: VideoSpec) -> Built:
    checkpoints = [f.local() for f in spec.checkpoints] or None
    pipe = GesturePipeline.from_pretrained(checkpoints=checkpoints, methods=list(spec.methods) or None)
    body = load_body_model(str(spec.body.local()) if spec.body is not None else None)
    return Built(pipe, body, load_character(spec.rig.local()) if spec.rig is not None else None, spec.size)


@contextlib.contextmanager
def reproducible() -> Iterator[None]:
    """One math thread and the default kernels (GESTURELSM_KERNELS=none) while inside; both restored after."""
    threads, kernels = torch.get_num_threads(), os.environ.get(KERNELS)
    torch.set_num_threads(1)
    os.environ[KERNELS] = "none"
    try:
        yield
    finally:
        torch.set_num_threads(threads)
        if kernels is None:
            os.environ.pop(KERNELS, None)
        else:
            os.environ[KERNELS] = kernels


def _speech(built: Built, unit: VideoUnit):
    key = (hashlib.blake2b(unit.audio.tobytes(), digest_size=16).hexdigest(), unit.words, unit.text,
           unit.plan.settings.language)
    if key not in built.speech:
        built.speech.clear()
        try:
            built.speech[key] = built.pipeline.prepare_speech(unit.audio, words=list(unit.words) if unit.words
                                                              else None, text=unit.text,
                                                              language=unit.plan.settings.language, stream=True)
        except ValueError as exc:                # InputError: too short, silent, too long
            raise type(exc)(f"{unit.audio_name}: {exc}") from None
    return built.speech[key]


def make_video(built: Built, unit: VideoUnit) -> VideoFiles:
    """The unit's motion (and, unless `render` is False, its video and character file), as bytes."""
    with reproducible():
        speech = _speech(built, unit)
        plan = replace(unit.plan, beat2=str(unit.take.local()) if unit.take is not None else None)
        made = {x.method: x.motion for x in built.pipeline.generate_each(speech, plan, body=built.body)}
        speech = built.pipeline.settled(speech)                      # generated while the words were recognised
        built.speech.update((k, built.pipeline.settled(v)) for k, v in list(built.speech.items()))
    motion = made.get(unit.method)
    if motion is None:
        return VideoFiles(None, None, note=f"{unit.audio_name}: not a take of the BEAT2 folder; no ground-truth video")
    if not unit.render:
        return VideoFiles(None, npz_bytes(motion))
    with tempfile.TemporaryDirectory(prefix="gesturelsm-video-") as tmp:
        path = Path(tmp) / unit.video
        render_video([motion], speech.audio, path, size=(built.size, built.size), body=built.body,
                     character=built.rig, grounding=unit.plan.settings.post.grounding)
        rig = None
        if built.rig is not None:
            suffix = ".vrm" if built.rig.skeleton.kind.startswith("vrm") else ".glb"
            rig = (suffix, export_rig_glb(motion, built.rig, path.with_suffix(suffix), body=built.body,
                                          grounding=unit.plan.settings.post.grounding).read_bytes())
        return VideoFiles(path.read_bytes(), npz_bytes(motion), rig)


def motion_path(out: Path, video: str) -> Path:
    return out / MOTION_DIR / Path(video).with_suffix(".npz").name


def finished(out: Path, video: str) -> tuple[bool, bool]:
    """(the video exists, its motion exists)."""
    return (out / "videos" / video).exists(), motion_path(out, video).exists()


def write_video(out: Path, unit: VideoUnit, files: VideoFiles) -> bool:
    """Write a unit's files, each whole, the video last; returns whether a video was written."""
    if files.motion is not None:
        write_atomic(motion_path(out, unit.video), files.motion)
    if files.rig is not None:
        write_atomic((out / "videos" / unit.video).with_suffix(files.rig[0]), files.rig[1])
    if files.video is not None:
        write_atomic(out / "videos" / unit.video, files.video)
    return files.video is not None


def transcript(audio: Path) -> tuple[list | None, str | None]:
    """(words, text) from <stem>.TextGrid or <stem>.txt beside the audio, else (None, None)."""
    tg = audio.with_suffix(".TextGrid")
    if tg.exists():
        return read_result(tg).words, None
    txt = audio.with_suffix(".txt")
    return None, (txt.read_text().strip() if txt.exists() else None)


def units_to_make(items, audio_files: list[Path], out: Path, base: Plan, ship: bool) -> tuple[list[Unit], int]:
    """A unit per study item (.video, .audio, .method) whose video or motion is missing (with the video there,
    the unit only generates); and how many are finished."""
    units, skipped = [], 0
    for a in audio_files:
        mine = [(it, *finished(out, it.video)) for it in items if it.audio == a.name]
        todo = [(it, have_video) for it, have_video, have_motion in mine if not (have_video and have_motion)]
        skipped += len(mine) - len(todo)
        if not todo:
            continue
        words, text = transcript(a)
        audio = load_audio(a)
        for it, have_video in todo:
            take = _take(base.beat2, audio, a.name, ship) if it.method == GROUND_TRUTH else None
            plan = replace(base, settings=replace(base.settings, methods=(it.method,)), filename=a.name, beat2=None)
            unit = VideoUnit(it.video, a.name, it.method, plan, audio, tuple(words) if words else None, text, take,
                             render=not have_video)
            units.append(Unit(it.video, unit, cost=1.0 if have_video else 4.0, label=f"{a.name}, {it.method}"))
    return units, skipped


def _take(beat2: str | None, audio: np.ndarray, name: str, ship: bool) -> Files | None:
    """The BEAT2 take this speech is (found here, where the folder is): its motion and speech file."""
    take = find_beat2_take(beat2, audio, name)
    if take is None:
        return None
    return Files.of(beat2, ship, only=[f"smplxflame_30/{take}.npz", f"wave16k/{take}.wav"])


def render_missing(items, audio_files: list[Path], out: Path, base: Plan, spec: VideoSpec, built: Built,
                   log, connection: Connection | None) -> tuple[int, int, RunReport]:
    """Every missing video (or motion) through its unit, here (with `built`) or on the cluster; -> (videos written,
    videos already there, the run's report)."""
    (out / "videos").mkdir(parents=True, exist_ok=True)
    units, skipped = units_to_make(items, audio_files, out, base, ship=connection is not None)
    bar = ProgressLine()
    rendered = 0

    def write(unit: Unit, files: VideoFiles) -> None:
        nonlocal rendered
        if files.note:
            bar.write(f"  {files.note}")
        if write_video(out, unit.inputs, files):
            rendered += 1
            bar.write(f"  {unit.key}  ({rendered} rendered)")

    if connection is not None:
        log(f"{len(units)} video(s) to make on the {connection.describe()}")
    report = run_units(Job(make_video, build, spec), units, write, connection=connection,
                       built=built if connection is None else None, progress=bar if units else None, noun="videos")
    return rendered, skipped, report


__all__ = ["Built", "MOTION_DIR", "VideoFiles", "VideoSpec", "VideoUnit", "build", "finished", "make_video",
           "motion_path", "reproducible", "render_missing", "transcript", "units_to_make", "write_video"]
