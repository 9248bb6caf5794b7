"""`gesturelsm edit` on tiny checkpoints: the flags as the docs write them, the file it writes, and one clear line
(exit status 2) for each kind of bad input."""
from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf

from gesturelsm.cli import main
from gesturelsm.commands.edit import parse_regenerate
from gesturelsm.errors import UserError
from gesturelsm.motion import MotionSequence
from gesturelsm.motion.regions import REGIONS
from _support import speech_like


@pytest.fixture(scope="module")
def files(tiny_assets, tmp_path_factory):
    """speech.wav (6 s) and motion.npz, the motion `gesturelsm generate` made of it."""
    d = tmp_path_factory.mktemp("edit_cli")
    sf.write(d / "speech.wav", speech_like(6.0), 16000)
    assert main(["generate", str(d / "speech.wav"), "--checkpoints", str(tiny_assets), "--steps", "2",
                 "--no-transcribe", "--out", str(d / "motion.npz")]) == 0
    return d


def test_regions_and_ranges_parse_as_written():
    assert parse_regenerate(["upper,hands@3.0-6.0", "face@10-12", "upper@7-8"]) == {
        "upper": [(3.0, 6.0), (7.0, 8.0)], "hands": [(3.0, 6.0)], "face": [(10.0, 12.0)]}
    # the regions' case and the numbers' sign are left to the edit's checks (unknown region, outside the speech)
    assert parse_regenerate(["Upper, HANDS@-1-3", "lower@2--1"]) == {
        "upper": [(-1.0, 3.0)], "hands": [(-1.0, 3.0)], "lower": [(2.0, -1.0)]}
    for bad in ("upper@3", "upper 3-6", "@3-6", "upper@a-b", "upper@1.2.3-4", " , @1-2"):
        with pytest.raises(UserError, match="REGIONS@START-END|not a range of seconds|name the regions before @"):
            parse_regenerate([bad])


def test_edit_writes_the_motion_with_the_rest_kept(files, tiny_assets, tmp_path, capsys):
    out = tmp_path / "edited.npz"
    assert main(["edit", str(files / "motion.npz"), str(files / "speech.wav"), "--regenerate", "upper,hands@2.0-4.0",
                 "--keyframe", f"{files / 'motion.npz'}:10@3.0", "--keyframe", "150@3.5",
                 "--checkpoints", str(tiny_assets), "--steps", "2", "--seed", "3", "--no-transcribe",
                 "--out", str(out), "--bvh", str(tmp_path / "edited.bvh")]) == 0
    printed = capsys.readouterr().out
    assert "upper 2-4 s; hands 2-4 s regenerated with gesturelsm, 2 steps, CFG 2, seed 3, 2 keyframe(s)" in printed
    before, after = MotionSequence.load(files / "motion.npz"), MotionSequence.load(out)
    assert after.num_frames == before.num_frames
    low = list(REGIONS["lower"].joints)
    assert np.array_equal(after.poses.reshape(-1, 55, 3)[:, low], before.poses.reshape(-1, 55, 3)[:, low])
    assert np.array_equal(after.trans, before.trans) and np.array_equal(after.expressions, before.expressions)
    up = list(REGIONS["upper"].joints)
    assert np.allclose(after.poses.reshape(-1, 55, 3)[90, up], before.poses.reshape(-1, 55, 3)[10, up], atol=1e-5)
    assert (tmp_path / "edited.bvh").read_text().startswith("HIERARCHY")


@pytest.mark.parametrize("extra, message", [
    (["--regenerate", "upper@5-9"], "the range 5-9 s of upper lies outside the speech (0-6.00 s)"),
    (["--regenerate", "elbows@1-2"], "unknown region 'elbows'"),
    (["--regenerate", "upper@4-2"], "the range 4-2 s of upper is reversed"),
    (["--regenerate", "upper@-1-2"], "the range -1-2 s of upper lies outside the speech (0-6.00 s)"),
    (["--regenerate", "upper@2-2"], "the range 2-2 s of upper is empty"),
    (["--regenerate", "Elbows@1-2"], "unknown region 'elbows'; the regions are upper, hands, lower, face"),
    (["--regenerate", "upper@1-3", "--keyframe", "nope.npz:3@2"], "keyframe pose: nope.npz: file not found"),
    (["--regenerate", "upper@1-3", "--keyframe", "pose@2"], "FILE.npz:FRAME"),
    (["--regenerate", "upper@1-3", "--keyframe", "12"], "write POSE.npz:FRAME@TIME"),
    (["--regenerate", "upper@1-3", "--method", "meanflow_authors"], "no checkpoint for meanflow_authors"),
    ([], "nothing to regenerate"),
])
def test_bad_input_is_one_line_and_status_2(files, tiny_assets, tmp_path, capsys, extra, message):
    code = main(["edit", str(files / "motion.npz"), str(files / "speech.wav"), "--checkpoints", str(tiny_assets),
                 "--steps", "2", "--no-transcribe", "--out", str(tmp_path / "x.npz"), *extra])
    err = [line for line in capsys.readouterr().err.splitlines() if not line.startswith("[")]   # not progress
    assert code == 2 and len(err) == 1 and message in err[0], err
    assert not (tmp_path / "x.npz").exists()


def test_arguments_are_checked_together_and_the_edit_before_the_models_load(files, tiny_assets, tmp_path, capsys):
    code = main(["edit", str(tmp_path / "none.npz"), str(files / "speech.wav"), "--regenerate", "upper 1-2",
                 "--seed", "1.5", "--steps", "0", "--checkpoints", str(tiny_assets), "--out", str(tmp_path / "x.npz")])
    err = capsys.readouterr().err
    assert code == 2
    for problem in ("MOTION", "none.npz: file not found", "--regenerate 'upper 1-2'", "--seed", "--steps"):
        assert problem in err, (problem, err)
    code = main(["edit", str(files / "motion.npz"), str(files / "speech.wav"), "--regenerate", "upper@5-9",
                 "--checkpoints", str(tiny_assets), "--no-transcribe", "--out", str(tmp_path / "x.npz")])
    err = capsys.readouterr().err
    assert code == 2 and "lies outside the speech" in err and "loading the models" not in err, err


def test_a_motion_that_is_not_the_speechs_length_or_not_a_motion(files, tiny_assets, tmp_path, capsys):
    short = MotionSequence.load(files / "motion.npz").slice(0, 90)
    short.save(tmp_path / "short.npz")
    (tmp_path / "text.npz").write_text("hello")
    for motion, message in ((tmp_path / "short.npz", "the motion is 3.00 s long but the speech 6.00 s"),
                            (tmp_path / "text.npz", "text.npz: not a .npz motion file (a BEAT2-layout .npz")):
        code = main(["edit", str(motion), str(files / "speech.wav"), "--regenerate", "upper@1-2", "--checkpoints",
                     str(tiny_assets), "--no-transcribe", "--out", str(tmp_path / "x.npz")])
        err = capsys.readouterr().err
        assert code == 2 and message in err, err


@pytest.mark.parametrize("extra, message", [
    (["--regenerate", "upper@0-1" + "0" * 308], "lies outside the speech (0-6.00 s)"),          # 1e308 s: no overflow
    (["--regenerate", "upper@99999999999999999999-1" + "0" * 400], "is not a number of seconds"),   # inf
    (["--regenerate", "upper@1-3", "--keyframe", "²@2"], "write the frame number in the digits 0-9"),
    (["--regenerate", "upper@1-3", "--keyframe", "٣@2"], "write the frame number in the digits 0-9"),
    (["--regenerate", "upper@1-3", "--keyframe", "40@٢"], "write POSE.npz:FRAME@TIME"),
    (["--regenerate", "upper@1-3", "--keyframe", "pose.npz:²@2"], "the frame number '²' is not written in the digits"),
    (["--regenerate", "upper@1-3", "--keyframe", "40@1e999"], "is not a time in seconds"),
    (["--regenerate", "upper@1-3", "--keyframe", "99999999999999999999999@2"], "frame 99999999999999999999999 is not"),
    (["--regenerate", "upper@1-3", "--out", "/proc/x.npz"], "--out /proc/x.npz: cannot write in /proc"),
    (["--regenerate", "upper@1-3", "--bvh", "/proc/self/x.bvh"], "--bvh /proc/self/x.bvh: cannot write in"),
    (["--regenerate", "upper@1-3", "--max-seconds", "5"],
     "motion.npz is 6 s long; the limit is 5 s: give --max-seconds 6 to edit it (at most 3600, as for generate)"),
    (["--regenerate", "upper@1-3", "--max-seconds", "3601"], "--max-seconds must be a number above 0 and at most 3600"),
])
def test_crafted_arguments_are_refused_before_any_model_loads(files, tmp_path, capsys, monkeypatch, extra, message):
    """Each a line and status 2, and no model is loaded for any of them (a model load would fail the
    test: the refusal comes from the arguments, the motion and the speech alone)."""
    from gesturelsm.pipeline import GesturePipeline

    def forbidden(*a, **k):
        raise AssertionError("the models were loaded before the arguments were refused")

    monkeypatch.setattr(GesturePipeline, "from_pretrained", classmethod(forbidden))
    argv = ["edit", str(files / "motion.npz"), str(files / "speech.wav"), "--no-transcribe"]
    code = main(argv + (["--out", str(tmp_path / "x.npz")] if "--out" not in extra else []) + extra)
    err = [line for line in capsys.readouterr().err.splitlines() if not line.startswith("[")]
    assert code == 2 and len(err) == 1 and message in err[0], err
    assert not (tmp_path / "x.npz").exists() and "Traceback" not in err[0]


def test_edit_reuses_the_words_the_motion_was_made_with(files, tiny_assets, tmp_path, capsys):
    """A motion that keeps its transcript and word timings (as generate writes them) is edited with them when no
    --text, --textgrid or --no-transcribe is given: nothing is transcribed again, and the edit keeps them."""
    seq = MotionSequence.load(files / "motion.npz")
    from dataclasses import replace

    seq = replace(seq, transcript="hello there", words=(("hello", 0.5, 1.0), ("there", 1.2, 1.8)))
    seq.save(tmp_path / "worded.npz")
    assert main(["edit", str(tmp_path / "worded.npz"), str(files / "speech.wav"), "--regenerate", "upper@2-3",
                 "--checkpoints", str(tiny_assets), "--steps", "2", "--out", str(tmp_path / "e.npz")]) == 0
    out = capsys.readouterr()
    assert "using the 2 word timings kept in worded.npz" in out.err + out.out
    assert "transcript with given word timings" in out.out
    edited = MotionSequence.load(tmp_path / "e.npz")
    assert [w for w, _, _ in edited.words] == ["hello", "there"]


def test_speech_hours_longer_than_the_motion_is_refused_without_decoding_it(files, tmp_path, capsys, monkeypatch):
    from _hostile import silent_flac
    from gesturelsm.pipeline import GesturePipeline

    monkeypatch.setattr(GesturePipeline, "from_pretrained", classmethod(lambda cls, **k: pytest.fail("models")))
    silent_flac(tmp_path / "hours.flac", 3 * 3600.0)
    code = main(["edit", str(files / "motion.npz"), str(tmp_path / "hours.flac"), "--regenerate", "upper@1-2",
                 "--no-transcribe", "--out", str(tmp_path / "x.npz")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "hours.flac is more than 60 s longer than the motion (6.00 s)" in err[0]


@pytest.mark.slow
def test_a_motion_longer_than_the_default_limit_edits_with_max_seconds(tiny_assets, tmp_path, capsys, monkeypatch):
    """A motion past the default 300 s (as `generate --max-seconds` makes them, up to an hour) is refused in one
    line before any model loads, naming the flag; with the flag it is edited, the rest kept bit for bit."""
    from gesturelsm.pipeline import GesturePipeline

    from _support import synthetic_motion

    seconds = 320
    synthetic_motion(frames=30 * seconds, seed=4).save(tmp_path / "long.npz")
    sf.write(tmp_path / "long.wav", speech_like(seconds, seed=4), 16000)
    argv = ["edit", str(tmp_path / "long.npz"), str(tmp_path / "long.wav"), "--regenerate", "upper@200-203",
            "--checkpoints", str(tiny_assets), "--steps", "1", "--no-transcribe", "--out", str(tmp_path / "e.npz")]
    with monkeypatch.context() as m:
        m.setattr(GesturePipeline, "from_pretrained", classmethod(lambda cls, **k: pytest.fail("models loaded")))
        assert main(argv) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if not line.startswith("[")]
    assert err == ["gesturelsm edit: error: long.npz is 320 s long; the limit is 300 s: give --max-seconds 320 to "
                   "edit it (at most 3600, as for generate)"]
    assert main(argv + ["--max-seconds", "320"]) == 0
    before, after = MotionSequence.load(tmp_path / "long.npz"), MotionSequence.load(tmp_path / "e.npz")
    assert after.num_frames == before.num_frames == 30 * seconds
    assert np.array_equal(after.poses[:5900], before.poses[:5900]) and np.array_equal(after.trans, before.trans)
    assert not np.array_equal(after.poses[6000:6090], before.poses[6000:6090])
