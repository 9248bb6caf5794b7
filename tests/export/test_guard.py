"""The writers' guard (export/guard.py): no writer writes a non-finite number, a frame rate that is not a finite
positive number, or animation times that do not increase, whichever path hands it the motion; nothing is written.
And generate keeps the words it was made with in the npz (transcript, words, word_times), which edit reuses."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import soundfile as sf

from gesturelsm.align.textgrid import write_textgrid
from gesturelsm.align.words import Word
from gesturelsm.cli import main
from gesturelsm.errors import GestureError, InputError
from gesturelsm.export import export_arkit, export_bvh, export_glb, export_keypoints, export_npz, npz_bytes
from gesturelsm.export.glb import FLOAT, GltfBuffer
from gesturelsm.export.guard import animation_times
from gesturelsm.motion import MotionSequence
from _support import speech_like


def _bad(wild_motion):
    nan_expr = wild_motion.expressions.copy()
    nan_expr[3, 2] = np.nan
    nan_betas = wild_motion.betas.copy()
    nan_betas[0] = np.inf
    nan_poses = wild_motion.poses.copy()
    nan_poses[1, 5] = np.nan
    return {"NaN expressions": replace(wild_motion, expressions=nan_expr),
            "inf betas": replace(wild_motion, betas=nan_betas),
            "NaN poses": replace(wild_motion, poses=nan_poses),
            "0 fps": replace(wild_motion, fps=0), "-30 fps": replace(wild_motion, fps=-30),
            "no frames": wild_motion.slice(0, 0)}


@pytest.mark.parametrize("case", ["NaN expressions", "inf betas", "NaN poses", "0 fps", "-30 fps", "no frames"])
def test_every_writer_refuses_and_writes_nothing(wild_motion, body, tmp_path, case):
    seq = _bad(wild_motion)[case]
    writers = {"a.npz": lambda p: export_npz(seq, p), "a.bvh": lambda p: export_bvh(seq, p, body=body),
               "a.glb": lambda p: export_glb(seq, p, body=body),
               "a.json": lambda p: export_keypoints(seq, p, body=body),
               "a.csv": lambda p: export_arkit(seq, p, body=body), "s.npz": lambda p: seq.save(p)}
    for name, write in writers.items():
        with pytest.raises(GestureError, match="NaN or infinite|frame rate|no frames|fps"):
            write(tmp_path / name)
    with pytest.raises(GestureError):
        npz_bytes(seq)
    assert list(tmp_path.iterdir()) == []


def test_gltf_values_and_times_are_guarded_at_the_buffer():
    with pytest.raises(InputError, match="NaN or infinite"):
        GltfBuffer().add(np.array([0.0, np.nan], np.float32), FLOAT, "SCALAR")
    for fps in (0, -30, float("nan"), float("inf")):
        with pytest.raises(InputError, match="frame rate"):
            animation_times(10, fps)
    assert np.all(np.diff(animation_times(108_000, 30)) > 0)          # an hour of frames still increases


def test_generate_keeps_its_words_in_the_npz_for_edit(tiny_assets, tmp_path, capsys):
    sf.write(tmp_path / "s.wav", speech_like(2.0, seed=5), 16000)
    write_textgrid(tmp_path / "s.TextGrid", [Word("hello", 0.2, 0.6), Word("there", 0.8, 1.4)], duration=2.0)
    assert main(["generate", str(tmp_path / "s.wav"), "--checkpoints", str(tiny_assets), "--steps", "1",
                 "--textgrid", str(tmp_path / "s.TextGrid"), "--out", str(tmp_path / "m.npz")]) == 0
    with np.load(tmp_path / "m.npz", allow_pickle=False) as d:
        assert list(d["words"]) == ["hello", "there"] and d["word_times"].dtype == np.float32
        assert np.allclose(d["word_times"], [[0.2, 0.6], [0.8, 1.4]]) and str(d["transcript"]) == "hello there"
        assert {"poses", "trans", "expressions", "betas", "model", "gender", "mocap_frame_rate"} <= set(d.files)
    seq = MotionSequence.load(tmp_path / "m.npz")
    assert seq.words == (("hello", pytest.approx(0.2), pytest.approx(0.6)),
                         ("there", pytest.approx(0.8), pytest.approx(1.4)))
    assert main(["generate", str(tmp_path / "s.wav"), "--checkpoints", str(tiny_assets), "--steps", "1",
                 "--no-transcribe", "--out", str(tmp_path / "quiet.npz")]) == 0
    with np.load(tmp_path / "quiet.npz") as d:                          # audio only: no words kept
        assert "words" not in d.files and "transcript" not in d.files
