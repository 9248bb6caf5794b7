"""The appropriateness study (GENEA's speech appropriateness, `gesturelsm batch --design appropriateness`): does a
method's motion fit the speech it was made for better than its motion for other speech?

Videos: per method and speech A heard, beside the method's genuine video of A, a "mismatched" video: the picture of
the method's video for another speech B, cut to A's length from its start, with A's sound (re-encoded, so the cut
is exact). B is the next speech of the study (in name order, wrapping round) whose motion is at least as long as
A's; when none is, A has no trial for that method. Its motion (B's, cut) is kept beside the key like every video's.
key/conditions.csv lists both kinds with `video, method, speech, motion_of` (motion_of = speech when matched).

Results: per method, the share of answers that chose the matched video (ties left out), a 95 % percentile-bootstrap
interval over raters, and a two-sided binomial test against 50 % (chance); results/appropriateness.csv.
"""
from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np

from ..cluster import write_atomic
from ..constants import FPS
from ..export import npz_bytes
from ..motion import MotionSequence
from . import stats
from .naming import blinded_name

COLUMNS = ["video", "method", "speech", "motion_of", "audio"]


def _frames(out: Path, video: str) -> int | None:
    path = out / "key" / "motion" / Path(video).with_suffix(".npz").name
    if not path.exists():
        return None
    with np.load(path, allow_pickle=False) as z:
        return int(z["poses"].shape[0])


def _cut_video(src: Path, speech: Path, seconds: float, dst: Path) -> None:
    import imageio_ffmpeg

    tmp = dst.with_name(dst.stem + ".part.mp4")
    subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-loglevel", "error", "-i", str(src), "-i", str(speech),
                    "-map", "0:v:0", "-map", "1:a:0", "-t", f"{seconds:.6f}", "-c:v", "libx264", "-preset", "veryfast",
                    "-crf", "18", "-pix_fmt", "yuv420p", "-c:a", "aac", "-movflags", "+faststart", str(tmp)],
                   check=True)
    tmp.replace(dst)


def other_speech(names: list[str], frames: dict[str, int | None], k: int) -> str | None:
    """The speech whose motion goes with speech k's sound: the next one (wrapping round) at least as long."""
    want = frames[names[k]]
    if want is None:
        return None
    for j in range(1, len(names)):
        b = names[(k + j) % len(names)]
        if frames[b] is not None and frames[b] >= want:
            return b
    return None


def write_mismatched(plan, audio_files: list[Path], methods: list[str], log=print) -> list[dict]:
    """Make the mismatched videos (and their motions) that are missing; returns the key's rows for them and for
    the matched videos (conditions.csv's appropriateness columns)."""
    out = plan.out
    by = {(it.audio, it.method): it.video for it in plan.items}
    names = [a.name for a in audio_files]
    files = {a.name: a for a in audio_files}
    rows = [dict(video=it.video, method=it.method, speech=it.audio, motion_of=it.audio, audio=it.audio,
                 **plan.settings.get(it.method, {})) for it in plan.items if (out / "videos" / it.video).exists()]
    skipped = 0
    for m in methods:
        frames = {a: _frames(out, by[(a, m)]) if (out / "videos" / by[(a, m)]).exists() else None for a in names}
        for k, a in enumerate(names):
            b = other_speech(names, frames, k)
            if b is None:
                skipped += frames[a] is not None
                continue
            name = blinded_name(plan.salt, a, m, {**plan.settings.get(m, {}), "motion_of": b})
            dst = out / "videos" / name
            if not dst.exists():
                motion = MotionSequence.load(out / "key" / "motion" / Path(by[(b, m)]).with_suffix(".npz").name)
                write_atomic(out / "key" / "motion" / Path(name).with_suffix(".npz").name,
                             npz_bytes(motion.slice(0, frames[a])))
                _cut_video(out / "videos" / by[(b, m)], files[a], frames[a] / FPS, dst)
            rows.append(dict(video=name, method=m, speech=a, motion_of=b, audio=a, **plan.settings.get(m, {})))
    if skipped:
        log(f"{skipped} speech x method pair(s) without a trial: no other speech of the study is as long")
    return rows


def analyse(kept: list, cond, n_boot: int, seed: int) -> list[dict]:
    """Per method: matched share with a 95 % bootstrap interval over raters, answers (ties left out), p against
    50 %. `kept`: (rater, answers by trial) of the raters kept."""
    rows = []
    matched_video = {v for v in cond.genuine}
    method_of = {v: m for v, (_, m, _) in cond.other.items()}
    for name in cond.methods:
        per_rater, ties = [], 0
        for rater, answers in kept:
            picks = []
            for t in rater.trials:
                a = answers.get(t.index)
                if a is None or t.check or method_of.get(t.left, method_of.get(t.right)) != name:
                    continue
                if a["choice"] == "none":
                    ties += 1
                    continue
                chosen = t.left if a["choice"] == "left" else t.right
                picks.append(1.0 if chosen in matched_video else 0.0)
            per_rater.append(np.array(picks))
        share, low, high = stats.bootstrap_mean(per_rater, n_boot, seed)
        n = int(sum(len(p) for p in per_rater))
        k = int(sum(p.sum() for p in per_rater))
        rows.append(dict(method=name, matched_share=share, low=low, high=high, answers=n,
                         p_value=stats.sign_test(k, n - k), raters=sum(len(p) > 0 for p in per_rater), ties=ties))
    return rows


def markdown(rows: list[dict]) -> list[str]:
    lines = ["## Speech appropriateness (share of answers choosing the motion made for the speech heard; 50 % is "
             "chance; 95% bootstrap over raters; two-sided binomial test against 50 %)", "",
             "| method | matched share | 95% interval | answers | p | raters | ties |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        interval = "n/a" if r["raters"] < 2 else f"[{r['low']:.2f}, {r['high']:.2f}]"
        lines.append(f"| {r['method']} | {r['matched_share']:.2f} | {interval} | {r['answers']} | {r['p_value']:.3g}"
                     f"{' *' if r['p_value'] < 0.05 else ''} | {r['raters']} | {r['ties']} |")
    return lines


__all__ = ["COLUMNS", "analyse", "markdown", "other_speech", "write_mismatched"]
