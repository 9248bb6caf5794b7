"""Batch rendering for user studies (`gesturelsm batch`).

Output folder:
    videos/v_<10 hex>.mp4        one body per video, no labels; the name says nothing about the condition (it
                                 hashes a secret salt with the speech, the method and every setting that makes
                                 the video: naming.py)
    key/conditions.csv           video -> speech file, method and its settings (keep away from raters)
    key/motion/v_<10 hex>.npz    the motion behind each video (BEAT2 layout), to measure what raters saw
    key/salt.txt                 the secret that makes the names; reused on reruns so names stay stable
    key/mismatch.csv             attention-check videos: one clip's video (motion_of) with another clip's speech
                                 (--design appropriateness: no such checks; its mismatched videos are the trials'
                                 own, listed in conditions.csv with `speech` and `motion_of`: appropriateness.py)
    key/design.json, raters.json, links.csv   the study's one design (see design.py): pairwise or rating, its
                                 attention checks, one unguessable link per rater for `gesturelsm study serve`
    study.json                   the settings of the videos and the design; a rerun with other ones is refused
Reruns skip videos that exist with their motion (every file is written under a temporary name and renamed when
complete; a video's motion is made again alone when only it is missing) and may add speech files, methods and
raters; the key and the attention checks keep the rows of earlier runs. Each video is one unit of work (videos.py),
made in this process or, with --cluster, as a task on a Ray cluster; the files land the same either way.
"""
from __future__ import annotations

import csv
import json
import secrets
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable, Mapping

from ..backends import checkpoint_sources
from ..body.model import resolve_model_path
from ..cluster import Connection, Files
from ..errors import InputError, UserError
from ..pipeline import GROUND_TRUTH, Plan
from ..settings import DEFAULTS, Settings
from .appropriateness import COLUMNS, write_mismatched
from .design import Design, invite, read_raters, write_design
from .segments import check_lengths, cut_segments, read_segments
from .naming import SETTINGS_FILE, blinded_name, check_unchanged, file_label, read_settings, video_settings, \
    weights_digest
from .videos import Built, VideoSpec, render_missing

AUDIO_EXTENSIONS = (".wav", ".flac", ".mp3", ".ogg", ".m4a", ".webm", ".opus", ".aac")
@dataclass
class StudyItem:
    video: str          # file name under videos/
    audio: str          # speech file name (relative to the audio folder)
    method: str


@dataclass
class StudyPlan:
    out: Path
    salt: str
    items: list[StudyItem] = field(default_factory=list)
    settings: Mapping[str, Mapping] = field(default_factory=dict)     # method -> its videos' settings


def find_audio(audio_dir: str | Path) -> list[Path]:
    d = Path(audio_dir)
    if not d.is_dir():
        raise InputError(f"audio folder not found: {d}")
    files = sorted(p for p in d.iterdir() if p.suffix.lower() in AUDIO_EXTENSIONS and p.is_file())
    if not files:
        raise InputError(f"{d} has no audio files ({', '.join(AUDIO_EXTENSIONS)})")
    return files


def plan_study(audio_files: list[Path], methods: list[str], out: str | Path,
               settings: Mapping[str, Mapping] | None = None) -> StudyPlan:
    """Names for every speech x method made with `settings[method]` (naming.video_settings); the salt is created
    once and kept in key/salt.txt."""
    out = Path(out)
    salt_file = out / "key" / "salt.txt"
    if salt_file.exists():
        salt = salt_file.read_text().strip()
    else:
        salt = secrets.token_hex(8)
        salt_file.parent.mkdir(parents=True, exist_ok=True)
        salt_file.write_text(salt + "\n")
    settings = {m: dict((settings or {}).get(m, {})) for m in methods}
    items = [StudyItem(blinded_name(salt, a.name, m, settings[m]), a.name, m) for a in audio_files for m in methods]
    if len({i.video for i in items}) != len(items):
        raise InputError("two speech files share a name; rename them")
    return StudyPlan(out, salt, items, settings)


def make_study(pipeline, audio_dir: str | Path, out: str | Path, settings: Settings = DEFAULTS, *, raters: int = 10,
               size: int = 512, body=None, beat2: str | None = None, design: Design = Design(),
               log: Callable[[str], None] = print, rig=None, connection: Connection | None = None,
               checkpoints: list[Path] | None = None, segments: str | Path | None = None) -> StudyPlan:
    """Render what is missing and (re)write the key, the attention-check videos, the study's design and links up
    to `raters` raters (existing links are kept); returns the plan. A folder made with other settings is refused
    before anything is rendered (naming.check_unchanged). `settings`: the methods (ground truth among them needs
    `beat2`) and how each video is generated and post-processed (`gesturelsm.settings`; a method without steps runs
    its default). `rig`: a retarget.Character; each video then shows the character's own mesh and gets the motion
    on that character beside it (VIDEO.vrm / .glb, the same blinded name). Each video is a unit of work
    (videos.py): in this process, or with `connection` (gesturelsm.cluster) a task on its cluster, whose workers
    load `checkpoints` (what `checkpoint_sources` gave; default the shipped ones). Videos that fail are listed in a
    ClusterError once everything else is written. `segments`: a CSV of evaluation segments (segments.py); the study
    is then over those segments, cut from each speech's whole videos."""
    methods = list(dict.fromkeys(settings.methods))
    for m in methods:
        if m != GROUND_TRUTH and m not in pipeline.methods:
            raise InputError(f"unknown method {m!r}; available: {', '.join(pipeline.methods)}, ground_truth")
    if GROUND_TRUTH in methods and not beat2:
        raise UserError("ground_truth needs --beat2 (the BEAT2 folder the speech comes from)")
    if raters < 1:
        raise UserError("--raters must be at least 1")
    base = Plan(settings, beat2)
    pipeline.check_plan(base)
    steps = {m: settings.steps_for(m) for m in settings.generators}
    audio_files = find_audio(audio_dir)
    segs = read_segments(segments, audio_files) if segments is not None else None
    if segs is not None:
        audio_files = [a for a in audio_files if a.name in segs]
        check_lengths(segs, audio_files)
    out = Path(out)
    render = dict(size=size, body=file_label(body.path if body is not None else resolve_model_path(None)),
                  character=file_label(rig.path) if rig is not None else None)
    videos = {m: video_settings(base, m, render, None if m == GROUND_TRUTH else
                                weights_digest(pipeline.backends[m])) for m in methods}
    shape = {**asdict(design), **({"segments": file_label(Path(segments))} if segments is not None else {})}
    check_unchanged(out, videos, shape)
    plan = plan_study(audio_files, methods, out, videos)
    record = dict(audio_dir=str(audio_dir), raters=raters, steps=steps, cfg=settings.cfg, seed=settings.seed,
                  size=size, **asdict(settings.post), design=shape)
    _write_settings(out, plan, record)                 # before rendering: an interrupted run is resumed alike
    ship = connection is not None
    spec = VideoSpec(tuple(Files.of(c, ship) for c in (checkpoints or checkpoint_sources(None))),
                     tuple(m for m in methods if m != GROUND_TRUTH), Files.of(getattr(body, "path", None), ship),
                     Files.of(rig.path, ship) if rig is not None else None, size)
    done, skipped, report = render_missing(plan.items, audio_files, out, base, spec, Built(pipeline, body, rig, size),
                                           log, connection)
    if not report.done and not skipped:
        report.raise_failures("videos")                # nothing to write a study around
    _write_trials(plan, audio_files, methods, design, segs, log)
    write_design(out, design)
    have = len(read_raters(out))
    if have < raters:
        invite(out, raters - have)
    _write_settings(out, plan, record)
    log(f"{done} videos rendered, {skipped} already there; the key is {out / 'key' / 'conditions.csv'} (do not "
        f"give it to raters); {max(have, raters)} rater links (`gesturelsm study serve {out}`) in "
        f"{out / 'key' / 'links.csv'}")
    report.raise_failures("videos")                    # after everything else is written: a rerun makes only these
    return plan


def _write_trials(plan: StudyPlan, audio_files: list[Path], methods: list[str], design: Design,
                  segs: dict | None, log) -> None:
    """The key and the design's extra videos, over the whole speech files or (with segments) over the segments."""
    if segs is not None:
        files, items = cut_segments(plan, audio_files, segs, StudyItem)
        plan, audio_files = StudyPlan(plan.out, plan.salt, items, plan.settings), files
    _write_key(plan)
    if design.mode == "appropriateness":              # its own mismatches are the question, not attention checks
        _merge_csv(plan.out / "key" / "conditions.csv", write_mismatched(plan, audio_files, methods, log), COLUMNS)
    else:
        write_mismatch(plan, audio_files, methods)


def _write_settings(out: Path, plan: StudyPlan, record: dict) -> None:
    """study.json: this run's settings, with the methods and video settings of earlier runs kept."""
    old = read_settings(out)
    videos = {**old.get("videos", {}), **plan.settings}
    methods = list(dict.fromkeys([*old.get("methods", []), *plan.settings]))
    (out / SETTINGS_FILE).write_text(json.dumps(dict(record, methods=methods, videos=videos), indent=1) + "\n")


def write_mismatch(plan: StudyPlan, audio_files: list[Path], methods: list[str]) -> list[str]:
    """Attention-check videos: the video of speech k+1 (method k mod M) with the speech of file k, muxed
    without re-encoding the picture; key/mismatch.csv says which (with the rows of earlier runs whose videos are
    there). Needs two speech files at least. Returns this run's check videos."""
    import subprocess

    import imageio_ffmpeg

    if len(audio_files) < 2:
        return []
    rows = []
    by = {(it.audio, it.method): it.video for it in plan.items}
    for k, a in enumerate(audio_files):
        b, m = audio_files[(k + 1) % len(audio_files)], methods[k % len(methods)]
        src = plan.out / "videos" / by[(b.name, m)]
        if not src.exists():
            continue
        name = blinded_name(plan.salt, a.name, "mismatch", {"motion_of": src.name})
        dst = plan.out / "videos" / name
        if not dst.exists():
            tmp = dst.with_name(dst.stem + ".part.mp4")
            subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", "-i", str(src), "-i", str(a),
                            "-map", "0:v:0", "-map", "1:a:0", "-c:v", "copy", "-c:a", "aac", "-shortest",
                            "-movflags", "+faststart", str(tmp)], check=True)
            tmp.replace(dst)
        rows.append(dict(video=name, audio=a.name, motion_of=src.name))
    _merge_csv(plan.out / "key" / "mismatch.csv", rows, ["video", "audio", "motion_of"])
    return [r["video"] for r in rows]


def _write_key(plan: StudyPlan) -> None:
    """key/conditions.csv: every video of the plan with its speech, method and settings, and the rows of
    earlier runs whose videos are there (the same settings: a rerun with others is refused)."""
    rows = [dict(video=it.video, audio=it.audio, method=it.method, **plan.settings.get(it.method, {}))
            for it in plan.items]
    _merge_csv(plan.out / "key" / "conditions.csv", rows, ["video", "audio", "method", "steps", "cfg", "seed"])


def _merge_csv(path: Path, rows: list[dict], first: list[str]) -> None:
    """Write `rows` to `path`, after the rows already there whose video exists and is not among `rows`."""
    new = {r["video"] for r in rows}
    old = []
    if path.exists():
        with open(path, newline="") as fh:
            old = [r for r in csv.DictReader(fh) if r["video"] not in new and (path.parent.parent / "videos" /
                                                                                r["video"]).exists()]
    every = [*old, *rows]
    columns = list(dict.fromkeys([*first, *(k for r in every for k in r)]))
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=columns, restval="")
        w.writeheader()
        w.writerows({k: ("" if v is None else v) for k, v in r.items()} for r in every)


__all__ = ["AUDIO_EXTENSIONS", "StudyItem", "StudyPlan", "blinded_name", "find_audio", "make_study", "plan_study",
           "write_mismatch"]
