"""Helpers for tests/study: a study folder made the way `gesturelsm batch` makes one (same key, mismatch videos, design
and links), but with short synthetic videos instead of rendered ones, so server and browser tests take seconds."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def synthetic_video(path: Path, audio: np.ndarray, colour: tuple[int, int, int], seconds: float = 1.0,
                    size: int = 64, fps: int = 15) -> None:
    """`seconds` of a square of `colour` moving across a grey frame, with the speech `audio` (16 kHz)."""
    import imageio
    import soundfile as sf

    wav = path.with_suffix(".wav")
    sf.write(wav, audio[: int(seconds * 16000)], 16000)
    frames = []
    for k in range(int(seconds * fps)):
        f = np.full((size, size, 3), 200, np.uint8)
        x = int(k / (seconds * fps) * (size - 16))
        f[24:40, x:x + 16] = colour
        frames.append(f)
    with imageio.get_writer(path, fps=fps, codec="libx264", pixelformat="yuv420p", audio_path=str(wav),
                            audio_codec="aac", ffmpeg_params=["-movflags", "+faststart"], macro_block_size=16) as w:
        for f in frames:
            w.append_data(f)
    wav.unlink()


def make_synthetic_study(out: Path, methods=("alpha", "beta", "gamma"), speeches: int = 2, raters: int = 3,
                         mode: str = "pairwise", attention: float = 0.4, seconds: float = 1.0) -> Path:
    import soundfile as sf

    from _support import speech_like
    from gesturelsm.study.batch import _write_key, plan_study, write_mismatch
    from gesturelsm.study.design import Design, invite, write_design

    audio_dir = out.parent / (out.name + "_speech")
    audio_dir.mkdir(parents=True, exist_ok=True)
    files = []
    for s in range(speeches):
        f = audio_dir / f"speech{s}.wav"
        sf.write(f, speech_like(seconds, seed=s), 16000)
        files.append(f)
    plan = plan_study(files, list(methods), out, {m: dict(steps=1, cfg=2.0, seed=0) for m in methods})
    (out / "videos").mkdir(parents=True, exist_ok=True)
    colours = [(200, 40, 40), (40, 160, 40), (40, 40, 200), (200, 160, 0)]
    for it in plan.items:
        a = sf.read(audio_dir / it.audio, dtype="float32")[0]
        synthetic_video(out / "videos" / it.video, a, colours[list(methods).index(it.method) % 4], seconds)
    _write_key(plan)
    if mode == "appropriateness":                   # each video's motion, then the mismatched videos batch makes
        from gesturelsm.study.appropriateness import COLUMNS, write_mismatched
        from gesturelsm.study.batch import _merge_csv

        (out / "key" / "motion").mkdir(parents=True, exist_ok=True)
        for k, it in enumerate(plan.items):
            T = int(round(seconds * 30))
            np.savez(out / "key" / "motion" / it.video.replace(".mp4", ".npz"),
                     poses=np.full((T, 165), 0.01 * k, np.float32), trans=np.zeros((T, 3), np.float32))
        _merge_csv(out / "key" / "conditions.csv", write_mismatched(plan, files, list(methods)), COLUMNS)
    else:
        write_mismatch(plan, files, list(methods))
    write_design(out, Design(mode, attention, 0))
    invite(out, raters)
    return out


def csv_rows(path) -> list[dict]:
    """A CSV file's rows as dicts (results/*.csv, key/links.csv)."""
    import csv

    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def answer_all(folder, choose) -> None:
    """Every rater of the study in `folder` answers every trial through the database API, as the server records
    answers; `choose(rater_id, trial, genuine)` gives the choice ('left', 'right', ...)."""
    from gesturelsm.study import db
    from gesturelsm.study.design import read_conditions, read_raters

    genuine = {v: m for v, (_, m) in read_conditions(folder).genuine.items()}
    engine = db.open_db(db.default_url(folder))
    for rater in read_raters(folder).values():
        st = db.open_session(engine, rater.id, 0)
        for t in rater.trials:
            nxt = t.index + 1 if t.index + 1 < len(rater.trials) else None
            db.record(engine, rater.id, st.session, t.index, choice=choose(rater.id, t, genuine), ratings=None,
                      played=True, next_trial=nxt, n_trials=len(rater.trials))
