"""`gesturelsm batch` on tiny checkpoints: blinded names, key kept apart, per-rater orders and sheets,
HTML forms, attention-check videos, the web study's design and links, resumability."""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from _support import speech_like


@pytest.fixture(scope="module")
def study_assets(tiny_assets):
    return tiny_assets


@pytest.fixture
def audio_dir(tmp_path):
    d = tmp_path / "speech"
    d.mkdir()
    sf.write(d / "alpha.wav", speech_like(1.0, seed=1), 16000)
    sf.write(d / "beta.flac", speech_like(1.2, sr=22050, seed=2), 22050)
    (d / "beta.txt").write_text("hello there")
    (d / "notes.md").write_text("not audio")
    return d


def _rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.slow                       # a whole command in subprocesses: the full tier
def test_batch_study_layout_blinding_and_resume(study_assets, audio_dir, tmp_path):
    from gesturelsm.cli import main

    out = tmp_path / "study"
    argv = ["batch", "--audio-dir", str(audio_dir), "--methods", "gesturelsm", "ddim", "--out", str(out),
            "--raters", "3", "--steps", "1", "--ddim-steps", "2", "--size", "128", "--checkpoints", str(study_assets)]
    assert main(argv) == 0
    every = sorted(p.name for p in (out / "videos").iterdir())
    assert len(every) == 6 and all(v.startswith("v_") and v.endswith(".mp4") for v in every)
    for v in every:                                          # names say nothing about the condition
        assert not any(w in v for w in ("gesturelsm", "ddim", "alpha", "beta", "mismatch"))
    key = _rows(out / "key" / "conditions.csv")
    videos = sorted(r["video"] for r in key)
    # attention checks: each speech gets the other speech's video with its own sound
    mismatch = _rows(out / "key" / "mismatch.csv")
    assert sorted([r["video"] for r in mismatch] + videos) == every
    src = {r["video"]: (r["audio"], r["method"]) for r in key}
    assert sorted(r["audio"] for r in mismatch) == ["alpha.wav", "beta.flac"]
    assert all(src[r["motion_of"]][0] != r["audio"] for r in mismatch)
    assert sorted((r["audio"], src[r["motion_of"]][1]) for r in mismatch) == [("alpha.wav", "gesturelsm"),
                                                                                ("beta.flac", "ddim")]
    from gesturelsm.study.design import read_design, read_raters
    assert read_design(out).mode == "pairwise"
    raters = read_raters(out)
    assert len(raters) == 3 and all(len(t) >= 24 for t in raters)        # secrets.token_urlsafe(18)
    links = _rows(out / "key" / "links.csv")
    assert sorted(r["link"] for r in links) == sorted(f"/r/{t}" for t in raters)
    for r in raters.values():                    # two speeches x one pair of methods, plus checks
        real = [t for t in r.trials if not t.check]
        assert len(real) == 2 and {t.check for t in r.trials} <= {"", "mismatch", "repeat"}
        assert len(r.trials) > 2
    assert {(r["audio"], r["method"]) for r in key} == {(a, m) for a in ("alpha.wav", "beta.flac")
                                                         for m in ("gesturelsm", "ddim")}
    assert not any("conditions" in p.name for p in (out / "raters").rglob("*"))   # key kept apart
    orders = []
    for r in (1, 2, 3):
        d = out / "raters" / f"rater_{r:02d}"
        order = [row["video"] for row in _rows(d / "order.csv")]
        assert sorted(order) == videos
        sheet = _rows(d / "sheet.csv")
        assert [s["video"] for s in sheet] == order
        assert set(sheet[0]) >= {"realness", "synchrony", "smoothness"}
        form = (d / "form.html").read_text()
        assert form.count('type="radio"') == 4 * 3 * 5 and "../../videos/" in form
        assert all(f"../../videos/{v}" in form for v in order)
        orders.append(order)
    assert len({tuple(o) for o in orders}) > 1                # orders differ between raters

    # resumable: a rerun renders nothing, a deleted video is rendered again under the same name
    mtimes = {v: (out / "videos" / v).stat().st_mtime_ns for v in every}
    (out / "videos" / videos[0]).unlink()
    logs = []
    from gesturelsm.pipeline import GesturePipeline
    from gesturelsm.settings import Settings
    from gesturelsm.study import make_study

    pipe = GesturePipeline.from_pretrained(study_assets)
    make_study(pipe, audio_dir, out, Settings(("gesturelsm", "ddim"), {"gesturelsm": 1, "ddim": 2}), raters=3, size=128,
               log=logs.append)
    assert sorted(p.name for p in (out / "videos").iterdir()) == every
    assert "1 videos rendered, 3 already there" in logs[-1]
    assert all((out / "videos" / v).stat().st_mtime_ns == t for v, t in mtimes.items() if v != videos[0])
    assert read_raters(out) == raters                       # the links handed out stay valid


def test_batch_errors_are_clear(study_assets, tmp_path, capsys):
    from gesturelsm.cli import main

    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["batch", "--audio-dir", str(empty), "--out", str(tmp_path / "o"),
                 "--checkpoints", str(study_assets)]) == 2
    assert "no audio files" in capsys.readouterr().err
    d = tmp_path / "a"
    d.mkdir()
    sf.write(d / "x.wav", np.zeros(16000, np.float32), 16000)
    assert main(["batch", "--audio-dir", str(d), "--out", str(tmp_path / "o"), "--methods", "gesturelsm",
                 "--checkpoints", str(study_assets)]) == 2
    assert "x.wav" in capsys.readouterr().err
    assert main(["batch", "--audio-dir", str(d), "--out", str(tmp_path / "o"), "--methods", "ground_truth",
                 "--checkpoints", str(study_assets)]) == 2
    assert "--beat2" in capsys.readouterr().err
