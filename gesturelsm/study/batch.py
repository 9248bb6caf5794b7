"""Batch rendering for user studies (`gesturelsm batch`).

Output folder:
    videos/v_<10 hex>.mp4        one body per video, no labels; the name says nothing about the condition
    key/conditions.csv           video -> speech file, method, steps, CFG, seed (keep away from raters)
    key/salt.txt                 the secret that makes the names; reused on reruns so names stay stable
    raters/rater_NN/order.csv    that rater's randomised presentation order
    raters/rater_NN/sheet.csv    the same order with empty 1-5 columns: realness, synchrony, smoothness
    raters/rater_NN/form.html    the videos in that order with 1-5 radio buttons; "Save ratings" downloads
                                 a filled sheet.csv (works offline from the folder, no server)
    key/mismatch.csv             attention-check videos: one clip's video (motion_of) with another clip's speech
    key/design.json, raters.json, links.csv   the web study (see design.py): mode, attention checks, one
                                 unguessable link per rater for `gesturelsm study serve`
    study.json                   settings used
Reruns skip videos that exist (videos are written under a temporary name and renamed when complete).
"""
from __future__ import annotations

import csv
import hashlib
import html
import json
import secrets
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Mapping

import numpy as np

from ..align import read_result
from ..audio import load_audio
from ..backends import FACTS, checkpoint_sources
from ..cluster import Connection, Files, Job, ProgressLine, RunReport, Unit, run_units
from ..data.lookup import find_beat2_take
from ..motion.postprocess import DEFAULT_SMOOTHING
from ..pipeline import GROUND_TRUTH, Plan
from .design import SCALE_QUESTIONS, SCALES, Design, invite, read_raters, write_design
from .videos import Built, VideoFiles, VideoSpec, VideoUnit, build, finished, make_video, write_video

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

    def order(self, rater: int, seed: int = 0) -> list[StudyItem]:
        """Rater's presentation order: a permutation drawn from (seed, rater)."""
        rng = np.random.default_rng([seed, rater])
        return [self.items[i] for i in rng.permutation(len(self.items))]


def blinded_name(salt: str, audio: str, method: str) -> str:
    return "v_" + hashlib.sha256(f"{salt}|{audio}|{method}".encode()).hexdigest()[:10] + ".mp4"


def find_audio(audio_dir: str | Path) -> list[Path]:
    d = Path(audio_dir)
    if not d.is_dir():
        raise FileNotFoundError(f"audio folder not found: {d}")
    files = sorted(p for p in d.iterdir() if p.suffix.lower() in AUDIO_EXTENSIONS and p.is_file())
    if not files:
        raise ValueError(f"{d} has no audio files ({', '.join(AUDIO_EXTENSIONS)})")
    return files


def plan_study(audio_files: list[Path], methods: list[str], out: str | Path) -> StudyPlan:
    """Names for every speech x method; the salt is created once and kept in key/salt.txt."""
    out = Path(out)
    salt_file = out / "key" / "salt.txt"
    if salt_file.exists():
        salt = salt_file.read_text().strip()
    else:
        salt = secrets.token_hex(8)
        salt_file.parent.mkdir(parents=True, exist_ok=True)
        salt_file.write_text(salt + "\n")
    items = [StudyItem(blinded_name(salt, a.name, m), a.name, m) for a in audio_files for m in methods]
    if len({i.video for i in items}) != len(items):
        raise ValueError("two speech files share a name; rename them")
    return StudyPlan(out, salt, items)


def _transcript(audio: Path):
    """(words, text) from <stem>.TextGrid or <stem>.txt beside the audio, else (None, None)."""
    tg = audio.with_suffix(".TextGrid")
    if tg.exists():
        return read_result(tg).words, None
    txt = audio.with_suffix(".txt")
    return None, (txt.read_text().strip() if txt.exists() else None)


def make_study(pipeline, audio_dir: str | Path, methods: list[str], out: str | Path, *, raters: int = 10,
               steps: Mapping[str, int] | None = None, cfg: float = 2.0, seed: int = 0, size: int = 512,
               body=None, beat2: str | None = None, stand_in_place: bool = False, smoothing: str = DEFAULT_SMOOTHING,
               design: Design = Design(), log: Callable[[str], None] = print, rig=None,
               connection: Connection | None = None, checkpoints: list[Path] | None = None) -> StudyPlan:
    """Render what is missing and (re)write key, orders, sheets and forms, the attention-check videos, the
    web study's design, and links up to `raters` raters (existing links are kept); returns the plan.
    `steps`: per method (missing: the method's default). `rig`: a retarget.Character; each video then shows the
    character's own mesh and gets the motion on that character beside it (VIDEO.vrm / .glb, the same blinded
    name). Each video is a unit of work (videos.py): in this process, or with `connection` (gesturelsm.cluster) a
    task on its cluster, whose workers load `checkpoints` (what `checkpoint_sources` gave; default the shipped
    ones). Videos that fail are listed in a ClusterError once everything else is written."""
    methods = list(dict.fromkeys(methods))
    steps = {m: int((steps or {}).get(m, f.default_steps)) for m, f in FACTS.items()}
    for m in methods:
        if m != GROUND_TRUTH and m not in pipeline.methods:
            raise ValueError(f"unknown method {m!r}; available: {', '.join(pipeline.methods)}, ground_truth")
    if GROUND_TRUTH in methods and not beat2:
        raise ValueError("ground_truth needs --beat2 (the BEAT2 folder the speech comes from)")
    if raters < 1:
        raise ValueError("--raters must be at least 1")
    audio_files = find_audio(audio_dir)
    plan = plan_study(audio_files, methods, out)
    out = Path(out)
    base = Plan(methods, steps, cfg, seed, stand_in_place, smoothing, beat2)
    spec = VideoSpec(tuple(Files.of(c, ship=connection is not None) for c in (checkpoints or checkpoint_sources(None))),
                     tuple(m for m in methods if m != GROUND_TRUTH),
                     Files.of(getattr(body, "path", None), ship=connection is not None),
                     Files.of(rig.path, ship=connection is not None) if rig is not None else None, size)
    done, skipped, report = _render_missing(plan, audio_files, base, spec, Built(pipeline, body, rig, size), log,
                                            connection)
    if not report.done and not skipped:
        report.raise_failures("videos")             # nothing to write a study around
    _write_key(plan, dict(steps=steps, cfg=cfg, seed=seed))
    for r in range(1, raters + 1):
        _write_rater(plan, r, seed)
    write_mismatch(plan, audio_files, methods)
    write_design(out, design)
    have = len(read_raters(out))
    if have < raters:
        invite(out, raters - have)
    (out / "study.json").write_text(json.dumps(dict(audio_dir=str(audio_dir), methods=methods, raters=raters,
                                                   steps=steps, cfg=cfg, seed=seed, size=size,
                                                   stand_in_place=stand_in_place, smoothing=smoothing), indent=1))
    log(f"{done} videos rendered, {skipped} already there; {raters} rater sheets in {out / 'raters'}; "
        f"the key is {out / 'key' / 'conditions.csv'} (do not give it to raters); web study links "
        f"(`gesturelsm study serve {out}`) in {out / 'key' / 'links.csv'}")
    report.raise_failures("videos")                 # after everything else is written: a rerun makes only these
    return plan


def _units(plan: StudyPlan, audio_files: list[Path], base: Plan, ship: bool) -> tuple[list[Unit], int]:
    """A unit per video that is missing, or whose motion is (that one only generates); and how many are finished."""
    by_audio: dict[str, list[StudyItem]] = {}
    for it in plan.items:
        by_audio.setdefault(it.audio, []).append(it)
    units, skipped = [], 0
    for a in audio_files:
        todo = [(it, *finished(plan.out, it.video)) for it in by_audio[a.name]]
        todo = [(it, have_video) for it, have_video, have_motion in todo if not (have_video and have_motion)]
        skipped += len(by_audio[a.name]) - len(todo)
        if not todo:
            continue
        words, text = _transcript(a)
        audio = load_audio(a)
        for it, have_video in todo:
            take = _take(base.beat2, audio, a.name, ship) if it.method == GROUND_TRUTH else None
            unit = VideoUnit(it.video, a.name, it.method, replace(base, methods=[it.method], filename=a.name, beat2=None),
                             audio, tuple(words) if words else None, text, take, render=not have_video)
            units.append(Unit(it.video, unit, cost=1.0 if have_video else 4.0, label=f"{a.name}, {it.method}"))
    return units, skipped


def _take(beat2: str | None, audio, name: str, ship: bool) -> Files | None:
    """The BEAT2 take this speech is (found here, where the folder is): its motion and speech as Files."""
    take = find_beat2_take(beat2, audio, name)
    if take is None:
        return None
    return Files.of(beat2, ship, only=[f"smplxflame_30/{take}.npz", f"wave16k/{take}.wav"])


def _render_missing(plan: StudyPlan, audio_files: list[Path], base: Plan, spec: VideoSpec, built: Built,
                    log: Callable[[str], None], connection: Connection | None) -> tuple[int, int, RunReport]:
    """Every missing video through its unit, here or on the cluster; -> (videos written, videos already there, the
    run's report)."""
    units, skipped = _units(plan, audio_files, base, ship=connection is not None)
    bar = ProgressLine()
    rendered = 0

    def write(unit: Unit, files: VideoFiles) -> None:
        nonlocal rendered
        if files.note:
            bar.write(f"  {files.note}")
        if write_video(plan.out, unit.inputs, files):
            rendered += 1
            bar.write(f"  {unit.key}  ({rendered} rendered)")

    if connection is not None:
        log(f"{len(units)} video(s) to make on the {connection.describe()}")
    report = run_units(Job(make_video, build, spec), units, write, connection=connection,
                       built=built if connection is None else None, progress=bar if units else None, noun="videos")
    return rendered, skipped, report


def write_mismatch(plan: StudyPlan, audio_files: list[Path], methods: list[str]) -> list[str]:
    """Attention-check videos: the video of speech k+1 (method k mod M) with the speech of file k, muxed
    without re-encoding the picture; key/mismatch.csv says which. Needs two speech files at least."""
    import subprocess

    import imageio_ffmpeg

    rows = []
    if len(audio_files) < 2:
        return []
    by = {(it.audio, it.method): it.video for it in plan.items}
    for k, a in enumerate(audio_files):
        b, m = audio_files[(k + 1) % len(audio_files)], methods[k % len(methods)]
        src = plan.out / "videos" / by[(b.name, m)]
        if not src.exists():
            continue
        name = blinded_name(plan.salt, a.name, f"mismatch|{m}|{b.name}")
        dst = plan.out / "videos" / name
        if not dst.exists():
            tmp = dst.with_name(dst.stem + ".part.mp4")
            subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", "-i", str(src), "-i", str(a),
                            "-map", "0:v:0", "-map", "1:a:0", "-c:v", "copy", "-c:a", "aac", "-shortest",
                            "-movflags", "+faststart", str(tmp)], check=True)
            tmp.replace(dst)
        rows.append((name, a.name, src.name))
    with open(plan.out / "key" / "mismatch.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["video", "audio", "motion_of"])
        w.writerows(rows)
    return [r[0] for r in rows]


def _write_key(plan: StudyPlan, settings: dict) -> None:
    with open(plan.out / "key" / "conditions.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["video", "audio", "method", "steps", "cfg", "seed"])
        for it in plan.items:
            w.writerow([it.video, it.audio, it.method, "" if it.method == GROUND_TRUTH else settings["steps"][it.method],
                        settings["cfg"], settings["seed"]])


def _write_rater(plan: StudyPlan, rater: int, seed: int) -> None:
    d = plan.out / "raters" / f"rater_{rater:02d}"
    d.mkdir(parents=True, exist_ok=True)
    videos = [it.video for it in plan.order(rater, seed) if (plan.out / "videos" / it.video).exists()]
    with open(d / "order.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["position", "video"])
        w.writerows((i + 1, v) for i, v in enumerate(videos))
    with open(d / "sheet.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["rater", "position", "video", *SCALES, "comment"])
        w.writerows((rater, i + 1, v, *[""] * len(SCALES), "") for i, v in enumerate(videos))
    (d / "form.html").write_text(_form(rater, videos))


def _form(rater: int, videos: list[str]) -> str:
    blocks = []
    for i, v in enumerate(videos, 1):
        scales = "".join(
            f'<p>{html.escape(SCALE_QUESTIONS[s])}<br>' + " ".join(
                f'<label><input type="radio" name="{s}_{i}" value="{k}"> {k}</label>' for k in range(1, 6)) + "</p>"
            for s in SCALES)
        blocks.append(f'<section data-video="{html.escape(v)}"><h3>Video {i} of {len(videos)}</h3>'
                      f'<video src="../../videos/{html.escape(v)}" controls preload="none" width="480"></video>'
                      f'{scales}<p>Comment: <input type="text" name="comment_{i}" size="60"></p></section>')
    return f"""<!doctype html><html><head><meta charset="utf-8"><title>Gesture rating, rater {rater}</title>
<style>body{{font-family:sans-serif;max-width:900px;margin:auto}}section{{border-bottom:1px solid #ccc;padding:1em 0}}</style>
</head><body><h1>Gesture rating (rater {rater})</h1>
<p>Watch each video with sound, then rate it on the three 1-5 scales. Rate every video in the order shown.
When done, press <b>Save ratings</b> and send the downloaded file back.</p>
{''.join(blocks)}
<button id="save">Save ratings</button>
<script>
document.getElementById('save').onclick = () => {{
  const scales = {json.dumps(list(SCALES))};
  const rows = [['rater','position','video',...scales,'comment']];
  document.querySelectorAll('section').forEach((s, j) => {{
    const i = j + 1, get = n => (s.querySelector(`input[name="${{n}}_${{i}}"]:checked`) || {{value: ''}}).value;
    const c = s.querySelector(`input[name="comment_${{i}}"]`).value.replaceAll('"', '""');
    rows.push([{rater}, i, s.dataset.video, ...scales.map(get), `"${{c}}"`]);
  }});
  const blob = new Blob([rows.map(r => r.join(',')).join('\\n') + '\\n'], {{type: 'text/csv'}});
  const a = document.createElement('a'); a.href = URL.createObjectURL(blob);
  a.download = 'ratings_rater_{rater:02d}.csv'; a.click();
}};
</script></body></html>
"""


__all__ = ["AUDIO_EXTENSIONS", "SCALES", "StudyItem", "StudyPlan", "blinded_name", "find_audio", "make_study",
           "plan_study", "write_mismatch"]
