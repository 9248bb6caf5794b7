"""The authors' methods in `gesturelsm sweep`, like ours: a folder holding only their converted weights is swept
beside the shipped models, each cell is the motion that setting and seed generate alone."""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest
import soundfile as sf

from _support import speech_like
from gesturelsm.audio import load_audio
from gesturelsm.cli import main
from gesturelsm.evaluation.motion_stats import STATISTICS, SpeechContext, motion_statistics, speaker_reference
from gesturelsm.pipeline import ASSETS, GesturePipeline


def test_sweep_runs_the_authors_methods_beside_ours(ckpt_dir, tmp_path):
    wav = tmp_path / "speech.wav"
    sf.write(wav, speech_like(3.0, seed=5), 16000, subtype="FLOAT")
    out = tmp_path / "run"
    rc = main(["sweep", str(wav), "--checkpoints", str(ckpt_dir), "--methods", "meanflow_authors", "gesturelsm",
               "--steps", "1", "2", "--cfg", "1.5", "--seeds", "2", "--no-transcribe", "--out", str(out)])
    assert rc == 0
    rows = list(csv.DictReader((out / "sweep.csv").open()))
    assert [(r["method"], r["steps"]) for r in rows] == [("meanflow_authors", "1"), ("meanflow_authors", "2"),
                                                         ("gesturelsm", "1"), ("gesturelsm", "2"), ("speaker", "")]
    runs = json.loads((out / "sweep.json").read_text())["runs"]
    got = next(r for r in runs if (r["method"], r["steps"], r["seed"]) == ("meanflow_authors", 2, 1))

    pipe = GesturePipeline.from_pretrained(checkpoints=[ASSETS, ckpt_dir], warm_up=False)
    speech = pipe.prepare_speech(load_audio(wav), 16000, transcribe=False)
    res = pipe.generate(speech, steps=2, cfg=1.5, seed=1, method="meanflow_authors", output="raw")
    want = motion_statistics(res.motion.slice(0, speech.num_frames), None,
                             SpeechContext.of(speech.audio, speaker_reference().mean_speed))
    for s in STATISTICS:
        assert (got[s.key] is None and not np.isfinite(want[s.key])) or got[s.key] == pytest.approx(want[s.key]), s.key
    a, b = (next(r for r in runs if (r["method"], r["steps"], r["seed"]) == ("meanflow_authors", 1, k)) for k in (0, 1))
    assert a["wrist_speed"] != b["wrist_speed"]                   # the seeds give different motion
