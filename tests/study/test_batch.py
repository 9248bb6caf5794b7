"""`gesturelsm batch` on tiny checkpoints: blinded names that change with every setting that changes a video, key
kept apart, attention-check videos, the study's one design and its links, resumability, and a rerun with other
settings refused before it could make the key lie."""
from __future__ import annotations

import csv
import json
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
def test_batch_makes_one_study_design_blinded_and_resumable(study_assets, audio_dir, tmp_path):
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
    assert not (out / "raters").exists()                      # one design: no second, unanalysable one beside it
    assert not any("conditions" in p.name for p in out.iterdir())  # key kept apart
    assert main(["study", "results", str(out)]) == 1          # the study reads as one: nobody answered yet

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
                 "--design", "rating", "--checkpoints", str(study_assets)]) == 2
    assert "x.wav" in capsys.readouterr().err
    assert main(["batch", "--audio-dir", str(d), "--out", str(tmp_path / "o"), "--methods", "ground_truth",
                 "--checkpoints", str(study_assets)]) == 2
    assert "--beat2" in capsys.readouterr().err


def test_video_names_change_with_every_setting_that_changes_a_video(tmp_path):
    """Each setting the key records, and any generation setting or post-processing option added to the settings
    (gesturelsm.settings), gives the video another name, so a video made otherwise never passes for one already
    there; ground truth does not depend on steps."""
    from dataclasses import fields

    from gesturelsm.pipeline import GROUND_TRUTH, Plan
    from gesturelsm.settings import PostProcess, Settings
    from gesturelsm.study.batch import plan_study
    from gesturelsm.study.naming import video_settings

    render = dict(size=512, body="SMPLX_MANNEQUIN.npz mannequin-sha", character=None)
    base = Plan(Settings(("gesturelsm",), {"gesturelsm": 8}, 2.0, 0, PostProcess(False, "light")))
    settings = video_settings(base, "gesturelsm", render, "weights-one")
    changed = dict(steps=4, cfg=1.5, seed=1, smoothing="off", stand_in_place=True, grounding=False, size=256,
                   body="SMPLX_NEUTRAL.npz mannequin-sha", character="me.vrm mannequin-sha", weights="weights-two")
    plan_fields = ({f.name for f in fields(Settings)} - {"methods", "steps", "transcribe", "language", "post"}) | \
        {f.name for f in fields(PostProcess)}
    assert plan_fields <= set(changed), "a setting is missing from this test"
    assert set(settings) == set(changed)
    files = [Path("a.wav")]
    name = plan_study(files, ["gesturelsm"], tmp_path, {"gesturelsm": settings}).items[0].video
    names = {name}
    for key, value in changed.items():
        other = plan_study(files, ["gesturelsm"], tmp_path, {"gesturelsm": dict(settings, **{key: value})})
        names.add(other.items[0].video)
        assert other.items[0].video != name, key
    assert len(names) == len(changed) + 1
    added = plan_study(files, ["gesturelsm"], tmp_path, {"gesturelsm": dict(settings, floor="tilted")})
    assert added.items[0].video != name                      # a setting added later renames too
    gt = video_settings(base, GROUND_TRUTH, render, None)
    assert "steps" not in gt and "weights" not in gt


def test_a_changed_setting_is_refused_by_name(tmp_path):
    from gesturelsm.errors import UserError
    from gesturelsm.study.naming import check_unchanged

    videos = {"gesturelsm": dict(steps=8, cfg=2.0, smoothing="light", grounding=True), "ddim": dict(steps=20, cfg=2.0)}
    design = dict(mode="pairwise", attention=0.15, seed=0)
    (tmp_path / "study.json").write_text(json.dumps(dict(videos=videos, design=design)))
    check_unchanged(tmp_path, videos, design)                                           # the same: fine
    check_unchanged(tmp_path, {**videos, "rectified_flow": dict(steps=8)}, design)      # a method added: fine
    with pytest.raises(UserError, match=r"--steps / --ddim-steps for gesturelsm was 8, this run 4"):
        check_unchanged(tmp_path, {**videos, "gesturelsm": dict(videos["gesturelsm"], steps=4)}, design)
    with pytest.raises(UserError, match=r"--smoothing for gesturelsm was 'light', this run 'off'"):
        check_unchanged(tmp_path, {**videos, "gesturelsm": dict(videos["gesturelsm"], smoothing="off")}, design)
    with pytest.raises(UserError, match=r"--grounding for gesturelsm was True, this run False"):
        check_unchanged(tmp_path, {**videos, "gesturelsm": dict(videos["gesturelsm"], grounding=False)}, design)
    with pytest.raises(UserError, match=r"--design was 'pairwise', this run 'rating'"):
        check_unchanged(tmp_path, videos, dict(design, mode="rating"))
    (tmp_path / "study.json").write_text(json.dumps(dict(steps={"gesturelsm": 8}, cfg=2.0)))   # no record
    with pytest.raises(UserError, match="new --out folder"):
        check_unchanged(tmp_path, videos, design)


@pytest.mark.parametrize("flag, want", [([], True), (["--grounding", "off"], False), (["--grounding", "on"], True)])
def test_batch_grounding_flag_reaches_every_videos_plan(monkeypatch, tmp_path, flag, want):
    """`gesturelsm batch --grounding on|off` (default on) is the Plan every video is generated with."""
    from gesturelsm.cli import main
    from gesturelsm.pipeline import GesturePipeline
    from gesturelsm.study import batch as batch_module
    from gesturelsm.study import videos as videos_module

    plans = []

    class Stop(BaseException):
        """Raised once the plan is seen: the plan is all this test needs (a BaseException: the batch lists a video's
        Exception among its failures and goes on, and the CLI reports an Exception as an internal error)."""

    class Pipe:
        methods = ["gesturelsm"]
        backends = {"gesturelsm": None}

        def prepare_speech(self, *a, **k):
            return None

        def check_plan(self, plan):
            return None

        def generate_each(self, speech, plan, progress=None, body=None):
            plans.append(plan)
            raise Stop
            yield

    monkeypatch.setattr(GesturePipeline, "from_pretrained", classmethod(lambda cls, **k: Pipe()))
    monkeypatch.setattr(batch_module, "weights_digest", lambda backend: "w")
    monkeypatch.setattr(videos_module, "load_audio", lambda path: np.zeros(16000, np.float32))
    (tmp_path / "a").mkdir()
    sf.write(tmp_path / "a" / "s.wav", np.zeros(16000, np.float32), 16000)
    with pytest.raises(Stop):
        main(["batch", "--audio-dir", str(tmp_path / "a"), "--methods", "gesturelsm", "--out", str(tmp_path / "o"),
              "--raters", "1", "--design", "rating", *flag])
    assert [p.settings.post.grounding for p in plans] == [want]
    assert json.loads((tmp_path / "o" / "study.json").read_text())["grounding"] is want


@pytest.mark.slow                       # renders: the full tier
def test_a_rerun_with_other_settings_is_refused_and_the_key_describes_the_videos(study_assets, audio_dir, tmp_path,
                                                                                 capsys):
    from gesturelsm.cli import main

    def batch(out, steps="1", *extra):
        return main(["batch", "--audio-dir", str(audio_dir), "--methods", "gesturelsm", "ddim", "--out", str(out),
                     "--raters", "1", "--steps", steps, "--ddim-steps", "1", "--size", "128", "--checkpoints",
                     str(study_assets), *extra])

    out = tmp_path / "study"
    assert batch(out) == 0
    def files():                                  # the settings, the key and the motions behind the videos
        return {p.relative_to(out): p.read_bytes() for p in [out / "study.json", *(out / "key").rglob("*")]
                if p.is_file()}
    before = files()
    assert len([p for p in before if p.parent.name == "motion"]) == 4
    videos = sorted(p.name for p in (out / "videos").iterdir())
    capsys.readouterr()
    assert batch(out, "2") == 2
    err = capsys.readouterr().err
    assert "--steps / --ddim-steps for gesturelsm was 1, this run 2" in err and "for ddim" not in err
    assert batch(out, "1", "--smoothing", "off") == 2
    assert "--smoothing" in capsys.readouterr().err
    assert batch(out, "1", "--design", "rating") == 2
    assert "--design" in capsys.readouterr().err
    assert sorted(p.name for p in (out / "videos").iterdir()) == videos                 # nothing rendered
    assert files() == before
    key = _rows(out / "key" / "conditions.csv")
    assert {(r["method"], r["steps"], r["size"], r["smoothing"]) for r in key} == {
        ("gesturelsm", "1", "128", "light"), ("ddim", "1", "128", "light")}
    other = tmp_path / "other"                    # the same salt and speech, 2 steps: only gesturelsm is renamed
    (other / "key").mkdir(parents=True)
    (other / "key" / "salt.txt").write_bytes((out / "key" / "salt.txt").read_bytes())
    assert batch(other, "2") == 0

    def named(folder, method):
        return {r["video"] for r in _rows(folder / "key" / "conditions.csv") if r["method"] == method}
    assert not named(out, "gesturelsm") & named(other, "gesturelsm")
    assert named(out, "ddim") == named(other, "ddim")


def test_batch_refuses_before_loading_models_or_starting_ray(monkeypatch, tmp_path, capsys):
    """A pairwise study of one method, or a folder without speech, is refused from the arguments: no model is
    loaded and no cluster is joined (docs/CLUSTER.md: refusals come before any work)."""
    from gesturelsm.cli import main
    from gesturelsm.pipeline import GesturePipeline
    from gesturelsm.commands import batch as study_cli

    def forbidden(*a, **k):
        raise AssertionError("work started before the arguments were checked")

    monkeypatch.setattr(GesturePipeline, "from_pretrained", classmethod(forbidden))
    monkeypatch.setattr(study_cli, "connect", forbidden)
    (tmp_path / "a").mkdir()
    sf.write(tmp_path / "a" / "s.wav", np.zeros(16000, np.float32), 16000)
    assert main(["batch", "--audio-dir", str(tmp_path / "a"), "--methods", "gesturelsm", "--out",
                 str(tmp_path / "o"), "--cluster", "local"]) == 2
    assert "a pairwise study needs at least two methods" in capsys.readouterr().err
    (tmp_path / "empty").mkdir()
    assert main(["batch", "--audio-dir", str(tmp_path / "empty"), "--methods", "gesturelsm", "ddim", "--out",
                 str(tmp_path / "o"), "--cluster", "local"]) == 2
    assert "no audio files" in capsys.readouterr().err
