"""`gesturelsm sweep --cluster` and `gesturelsm eval --cluster` on a simulated two-node Ray cluster: every cell or
clip a task on a worker that gets the test checkpoints by value, and the same statistics and metrics as a run in
this process (only the timings may differ)."""
from __future__ import annotations

import contextlib
import csv
import io
import json
from pathlib import Path

import pytest
import soundfile as sf

from _support import speech_like, synthetic_motion

TIMED = {"time", "time_std", "seconds_per_clip", "real_time_factor"}


def _main(*argv: str) -> tuple[int, str]:
    from gesturelsm.cli import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(err):
        code = main(list(argv))
    return code, err.getvalue()


def _untimed(row: dict) -> dict:
    return {k: v for k, v in row.items() if k not in TIMED}


def test_a_sweep_on_the_cluster_measures_what_one_here_measures(ray_cluster, tiny_assets, tmp_path):
    wav = tmp_path / "speech.wav"
    sf.write(wav, speech_like(1.5, seed=3), 16000)
    common = ["sweep", str(wav), "--methods", "gesturelsm", "ddim", "--steps", "1", "2", "--cfg", "2", "--seeds", "1",
              "--no-transcribe", "--checkpoints", str(tiny_assets)]
    code, log = _main(*common, "--out", str(tmp_path / "here"))
    assert code == 0, log
    code, log = _main(*common, "--out", str(tmp_path / "there"), "--cluster", "auto")
    assert code == 0, log
    assert "4/4 motions" in log

    def rows(name):
        with open(tmp_path / name / "sweep.csv", newline="") as fh:
            return [_untimed(r) for r in csv.DictReader(fh)]
    here, there = rows("here"), rows("there")
    assert len(here) == 5 and here[-1]["method"] == "speaker" and here == there     # 4 cells, the speaker row


@pytest.fixture(scope="module")
def beat2(tmp_path_factory) -> Path:
    """Two motion takes of 4 s (speech-like audio), BEAT2 layout."""
    root = tmp_path_factory.mktemp("beat2")
    (root / "wave16k").mkdir()
    for i in (1, 2):
        synthetic_motion(frames=120, seed=i).save(root / "smplxflame_30" / f"2_test_0_{i}_{i}.npz")
        sf.write(root / "wave16k" / f"2_test_0_{i}_{i}.wav", speech_like(4.0, seed=i), 16000, subtype="FLOAT")
    return root


def test_an_evaluation_on_the_cluster_reports_what_one_here_reports(ray_cluster, tiny_assets, beat2, tmp_path):
    common = ["eval", "--data", str(beat2), "--checkpoints", str(tiny_assets), "--methods", "gesturelsm",
              "--steps", "1", "--seeds", "1", "--train-fraction", "0.5"]
    code, log = _main(*common, "--out", str(tmp_path / "here"))
    assert code == 0, log
    code, log = _main(*common, "--out", str(tmp_path / "there"), "--cluster", "auto")
    assert code == 0, log
    assert sorted(line for line in log.splitlines() if line.startswith("clip ")) == [
        "clip 1/2 2_test_0_1_1[60:120]: done", "clip 2/2 2_test_0_2_2[60:120]: done"]
    here, there = (json.loads((tmp_path / d / "eval.json").read_text()) for d in ("here", "there"))
    assert there["ground_truth"] == here["ground_truth"] and there["clips"] == here["clips"]
    assert [_untimed(r) for r in there["rows"]] == [_untimed(r) for r in here["rows"]]
    assert here["rows"][0]["heldout"]["fgd_k"] is not None
