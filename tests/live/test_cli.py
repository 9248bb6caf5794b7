"""`gesturelsm live FILE`: writes the streamed motion (offline frame count) and prints latency; bad input is one line."""
from __future__ import annotations

import numpy as np
import soundfile as sf

from gesturelsm.cli import main
from gesturelsm.motion.sequence import MotionSequence

from _support import speech_like


def test_live_cli_writes_motion_and_reports_latency(shipped_pipe, tmp_path, capsys):
    wav = tmp_path / "speech.wav"
    sf.write(wav, speech_like(2.5, seed=8), 16000)
    assert main(["live", str(wav), "--chunk-ms", "150", "--steps", "1", "--out", str(tmp_path / "m.npz")]) == 0
    out = capsys.readouterr().out
    assert "latency median" in out and "real-time factor" in out
    m = MotionSequence.load(tmp_path / "m.npz")
    assert m.num_frames == 75 and np.isfinite(m.poses).all()


def test_live_cli_bad_input_is_one_clear_line(tmp_path, capsys):
    assert main(["live", str(tmp_path / "missing.wav")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not found" in err[0]
    wav = tmp_path / "s.wav"
    sf.write(wav, speech_like(1.0), 16000)
    assert main(["live", str(wav), "--chunk-ms", "0"]) == 2
    assert "--chunk-ms" in capsys.readouterr().err
