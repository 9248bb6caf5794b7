"""`gesturelsm sweep` (evaluation/sweep.py, sweep_report.py, commands/sweep.py) on tiny checkpoints: the table and plot
hold exactly the grid's cells, each cell's numbers are those of its motions generated alone, bad grids are refused
with one line each and leave nothing behind, a cancelled sweep writes nothing."""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest
import soundfile as sf

from _support import speech_like
from gesturelsm.cli import main
from gesturelsm.errors import InputError
from gesturelsm.evaluation.motion_stats import STATISTICS, SpeechContext, motion_statistics, speaker_reference
from gesturelsm.evaluation.sweep import SweepCancelled, SweepGrid, SweepLimits, check_grid, run_sweep, sweep_grid
from gesturelsm.evaluation.sweep_limits import measures
from gesturelsm.evaluation.sweep_report import write_sweep
from gesturelsm.pipeline import GesturePipeline, finish


@pytest.fixture(scope="module")
def pipe(eval_assets):
    return GesturePipeline.from_pretrained(eval_assets, warm_up=False)


@pytest.fixture(scope="module")
def wav(tmp_path_factory):
    path = tmp_path_factory.mktemp("sweep") / "speech.wav"
    sf.write(path, speech_like(5.0, seed=3), 16000, subtype="FLOAT")
    return path


@pytest.fixture(scope="module")
def cli_run(eval_assets, wav, tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep_cli") / "run"
    rc = main(["sweep", str(wav), "--checkpoints", str(eval_assets), "--methods", "gesturelsm", "ddim",
               "--steps", "1", "2", "--cfg", "2", "--seeds", "2", "--no-transcribe", "--metric", "bc",
               "--out", str(out)])
    assert rc == 0
    return out


def test_sweep_cli_writes_one_row_per_cell_and_a_plot(cli_run):
    assert sorted(p.name for p in cli_run.iterdir()) == ["sweep.csv", "sweep.json", "sweep.md", "sweep.png"]
    rows = list(csv.DictReader((cli_run / "sweep.csv").open()))
    cells = [(r["method"], r["steps"], r["cfg"]) for r in rows]
    assert cells == [("gesturelsm", "1", "2"), ("gesturelsm", "2", "2"), ("ddim", "1", "2"), ("ddim", "2", "2"),
                     ("speaker", "", "")]
    assert all(r["seeds"] == "2" and float(r["time"]) > 0 for r in rows[:-1])
    assert (cli_run / "sweep.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    md = (cli_run / "sweep.md").read_text()
    assert md.count("| GestureLSM |") == 2 and md.count("| DDIM |") == 2 and "speaker (reference)" in md
    rep = json.loads((cli_run / "sweep.json").read_text())
    assert len(rep["runs"]) == 8 and {r["seed"] for r in rep["runs"]} == {0, 1}
    for row in rep["rows"]:                       # the table's means and spreads are those of the runs
        key = (row["method"], row["steps"], row["cfg"])
        runs = [r for r in rep["runs"] if (r["method"], r["steps"], r["cfg"]) == key]
        for k in ("time", "wrist_speed", "diversity"):
            v = [r[k] for r in runs]
            assert row[k] == pytest.approx(np.mean(v)) and row[f"{k}_std"] == pytest.approx(np.std(v))
        assert row["seed_spread"] >= 0
    assert all(r["seed_spread"] > 0 for r in rep["rows"] if r["method"] == "gesturelsm")   # seeds differ


def test_a_sweep_cell_is_the_motion_that_setting_and_seed_generate_alone(cli_run, pipe, wav):
    from gesturelsm.audio import load_audio

    audio = load_audio(wav)
    speech = pipe.prepare_speech(audio, 16000, transcribe=False)
    res = pipe.generate(speech, steps=2, cfg=2.0, seed=1, method="ddim", output="raw")
    motion, _ = finish(res.motion.slice(0, speech.num_frames), grounding=True)      # the sweep grounds the feet
    want = motion_statistics(motion, None, SpeechContext.of(speech.audio, speaker_reference().mean_speed))
    got = next(r for r in json.loads((cli_run / "sweep.json").read_text())["runs"]
               if (r["method"], r["steps"], r["seed"]) == ("ddim", 2, 1))
    for s in STATISTICS:
        assert (got[s.key] is None and not np.isfinite(want[s.key])) or got[s.key] == pytest.approx(want[s.key]), s.key


def test_sweep_grid_reads_lists_and_refuses_words_all_at_once():
    methods = ["gesturelsm", "ddim"]
    assert sweep_grid(methods, "1 2, 4 2", ["1.5", "2"], 2, methods) == SweepGrid(("gesturelsm", "ddim"), (1, 2, 4),
                                                                                     (1.5, 2.0), 2)
    with pytest.raises(InputError) as err:
        sweep_grid(["gesturelsm", "nope"], "1 2.5 inf", "1 x", 0, methods)
    assert str(err.value).splitlines() == [
        "Unknown method 'nope'; available: gesturelsm, ddim.", "--steps must be whole numbers (got 2.5).",
        "--cfg must be numbers (got 'x').", "--seeds must be from 1 to 4 (got 0)."]
    with pytest.raises(InputError, match=r"^--steps for GestureLSM must be from 1 to 128 \(got 500\)\.$"):
        sweep_grid(methods, "1 500", "2", 1, methods)


@pytest.mark.parametrize("grid, seconds, message", [
    (SweepGrid(("gesturelsm",), (), (2.0,)), 5, "Give at least one step count."),
    (SweepGrid(("gesturelsm",), (1, 200), (2.0,)), 5, "must be from 1 to 128"),
    (SweepGrid(("gesturelsm",), (1,), (-1.0,)), 5, "CFG scale for GestureLSM must be between 0 and"),
    (SweepGrid(("nope",), (1,), (2.0,)), 5, "unknown method 'nope'"),
    (SweepGrid(("gesturelsm",), tuple(range(1, 11)), tuple(range(8)), 1), 1, "a sweep takes at most 72"),
    (SweepGrid(("gesturelsm",), (1, 2), (1.0, 2.0), 3), 200, "2400 s of motion; a sweep makes at most 1500 s"),
    (SweepGrid(("gesturelsm",), (1,), (2.0,), 9), 5, "Seeds must be from 1 to 4"),
])
def test_bad_grids_are_refused_with_a_clear_line(pipe, grid, seconds, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(")):
        check_grid(pipe, grid, seconds, SweepLimits())


def test_sweep_cli_refuses_silence_and_bad_steps_leaving_no_output(eval_assets, tmp_path, capsys):
    silent = tmp_path / "silence.wav"
    sf.write(silent, np.zeros(32000, np.float32), 16000)
    for audio, extra, msg in [(silent, [], "silent"), (silent, ["--steps", "0"], "from 1 to")]:
        out = tmp_path / "out"
        rc = main(["sweep", str(audio), "--checkpoints", str(eval_assets), "--methods", "gesturelsm", "--no-transcribe",
                   "--out", str(out), *extra])
        err = capsys.readouterr().err
        assert rc == 2 and msg in err and "Traceback" not in err
        assert not out.exists() and [p.name for p in tmp_path.iterdir()] == ["silence.wav"]


def test_a_cancelled_sweep_stops_before_the_next_motion_and_writes_nothing(pipe, wav, tmp_path):
    from gesturelsm.audio import load_audio

    speech = pipe.prepare_speech(load_audio(wav), 16000, transcribe=False)
    asked = []
    with pytest.raises(SweepCancelled):
        run_sweep(pipe, speech, SweepGrid(("gesturelsm",), (1, 2), (2.0,), 1), cancelled=lambda: asked.append(1) or
                  len(asked) > 1)
    assert len(asked) == 2 and list(tmp_path.iterdir()) == []


def test_a_cancelled_token_stops_the_sweep_with_one_line(pipe, wav):
    from gesturelsm.audio import load_audio
    from gesturelsm.errors import Cancelled, CancelToken

    speech = pipe.prepare_speech(load_audio(wav), 16000, transcribe=False)
    token, said = CancelToken(), []

    def progress(f, m):
        said.append(m)
        if m.startswith("1/2 motions"):                     # the first motion is made: the tab's Cancel
            token.cancel()
    with pytest.raises(Cancelled, match="^The sweep was cancelled; nothing was written.$"):
        run_sweep(pipe, speech, SweepGrid(("gesturelsm",), (1, 2), (2.0,), 1), progress=progress, cancelled=token)
    assert not any(m.startswith("2/2") for m in said)


def test_write_sweep_replaces_an_earlier_sweep_in_place(pipe, wav, tmp_path):
    from gesturelsm.audio import load_audio

    speech = pipe.prepare_speech(load_audio(wav), 16000, transcribe=False)
    res = run_sweep(pipe, speech, SweepGrid(("rectified_flow",), (1,), (0.0,), 1))
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "sweep.csv").write_text("old")
    write_sweep(res, tmp_path / "out", metric="jerk")
    assert [p.name for p in tmp_path.iterdir()] == ["out"]            # no temporary folder left
    assert (tmp_path / "out" / "sweep.csv").read_text().startswith("method,steps,cfg")


class Recording:
    """A pipeline that records every generation it is asked for (method, steps, CFG, seed)."""

    def __init__(self, pipe):
        self.pipe, self.calls = pipe, []

    def generate(self, speech, **kw):
        self.calls.append((kw["method"], kw["steps"], kw["cfg"], kw["seed"]))
        return self.pipe.generate(speech, **kw)

    def __getattr__(self, name):
        return getattr(self.pipe, name)


def test_sweep_times_leave_out_each_methods_warm_up(pipe, wav):
    """A method's first call pays one-off costs (the first cell took 0.52 s against 0.23 s for the next seed, so 1 step
    plotted slower than 2): every method is run untimed once in each guidance mode before any cell is timed."""
    from gesturelsm.audio import load_audio

    speech = pipe.prepare_speech(load_audio(wav), 16000, transcribe=False)
    rec = Recording(pipe)
    res = run_sweep(rec, speech, SweepGrid(("gesturelsm", "ddim"), (1, 2), (1.0, 2.0), 1), keep_motions=False)
    timed = [(r.method, r.steps, r.cfg, r.seed) for r in res.runs]
    untimed = rec.calls[:len(rec.calls) - len(timed)]
    assert rec.calls[len(untimed):] == timed
    assert {(m, c == 1.0) for m, _, c, _ in untimed} == {(m, c == 1.0) for m, _, c, _ in timed}


def test_sweep_grounding_off_measures_the_samplers_own_motion(pipe, wav, tmp_path, eval_assets, capsys):
    from gesturelsm.audio import load_audio

    out = tmp_path / "off"
    speech = pipe.prepare_speech(load_audio(wav), 16000, transcribe=False)
    grid = SweepGrid(("ddim",), (2,), (2.0,), 1)
    ref = speaker_reference()
    raw = pipe.generate(speech, steps=2, cfg=2.0, seed=0, method="ddim", output="raw").motion
    raw = raw.slice(0, speech.num_frames)
    context = SpeechContext.of(speech.audio, ref.mean_speed)
    for grounding in (False, True):
        result = run_sweep(pipe, speech, grid, grounding=grounding, keep_motions=False)
        want = motion_statistics(finish(raw, grounding=grounding)[0], None, context)
        got = result.runs[0].statistics
        assert got["foot_skate"] == pytest.approx(want["foot_skate"]) and got["bob"] == pytest.approx(want["bob"])
        assert result.grounding is grounding
        write_sweep(result, out / str(grounding))
        md = (out / str(grounding) / "sweep.md").read_text()      # the table says what it measured (MEASURES)
        said = f"raw motion, not the finished motion: {'grounded' if grounding else 'not grounded'}, unsmoothed"
        assert md.startswith(f"Measured on {said}.\n") and measures(grounding) == said
        assert json.loads((out / str(grounding) / "sweep.json").read_text())["grounding"] is grounding
    assert main(["sweep", str(wav), "--checkpoints", str(eval_assets), "--methods", "ddim", "--steps", "2",
                 "--cfg", "2", "--seeds", "1", "--no-transcribe", "--grounding", "off", "--out", str(out / "cli")]) == 0
    rep = json.loads((out / "cli" / "sweep.json").read_text())
    assert "Measured on raw motion, not the finished motion: not grounded, unsmoothed." in capsys.readouterr().out
    assert rep["measures"] == measures(False)
    assert rep["grounding"] is False and rep["runs"][0]["bob"] == pytest.approx(
        motion_statistics(raw, None, context)["bob"])
