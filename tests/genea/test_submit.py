"""`gesturelsm genea submit`: a leaderboard-ready folder of seeded samples, and the checks that refuse the rest."""
from __future__ import annotations

import io
import json

import numpy as np
import pytest
import soundfile as sf

from _support import speech_like
from gesturelsm.cli import main
from gesturelsm.genea.submission import check_arrays, check_speech, take_of

TAKES = ("2_scott_0_2_2", "2_scott_0_3_3")


def _speech(folder, seconds=(2.5, 3.1)):
    folder.mkdir(parents=True, exist_ok=True)
    for k, (take, s) in enumerate(zip(TAKES, seconds)):
        sf.write(folder / f"{take}.wav", speech_like(s, seed=k), 16000)
    return dict(zip(TAKES, seconds))


def test_two_speech_files_three_samples_make_six_leaderboard_files(tiny_assets, tmp_path, capsys):
    seconds = _speech(tmp_path / "speech")
    out = tmp_path / "sub"
    assert main(["genea", "submit", str(tmp_path / "speech"), "--out", str(out), "--samples", "3",
                 "--checkpoints", str(tiny_assets), "--steps", "1", "--no-transcribe", "--seed", "7"]) == 0
    files = sorted(out.glob("*.npz"))
    assert [f.name for f in files] == [f"{t}_sample{k}.npz" for t in TAKES for k in (1, 2, 3)]
    for take, s in seconds.items():
        poses = []
        for k in (1, 2, 3):
            with np.load(out / f"{take}_sample{k}.npz", allow_pickle=False) as z:
                T = z["poses"].shape[0]
                assert abs(T - 30 * s) <= 1
                assert z["poses"].shape == (T, 165) and z["trans"].shape == (T, 3)
                assert z["expressions"].shape == (T, 100) and z["betas"].shape == (300,)
                assert str(z["gender"]) == "neutral" and int(z["mocap_frame_rate"]) == 30
                poses.append(z["poses"])
        assert not np.allclose(poses[0], poses[1]) and not np.allclose(poses[1], poses[2])
        assert take_of(f"{take}_sample1.npz") == take
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["settings"]["samples"] == 3 and manifest["settings"]["method"] == "gesturelsm"
    seeds = [manifest["files"][f"{TAKES[0]}_sample{k}.npz"]["seed"] for k in (1, 2, 3)]
    assert seeds == [7, 8, 9]
    assert manifest["checkpoints"] and all(len(h) == 64 for h in manifest["checkpoints"].values())
    assert {"gesturelsm", "torch", "numpy", "python"} <= set(manifest["versions"])
    assert "asks a non-deterministic system for 5" in capsys.readouterr().out


def test_a_speech_not_named_as_a_take_is_refused_before_any_work(tmp_path, capsys):
    (tmp_path / "speech").mkdir()
    sf.write(tmp_path / "speech" / "hello.wav", speech_like(2.0), 16000)
    assert main(["genea", "submit", str(tmp_path / "speech"), "--out", str(tmp_path / "sub")]) == 2
    err = capsys.readouterr().err
    assert "would not accept" in err and "hello: not a BEAT2 take's name" in err
    assert not list((tmp_path / "sub").glob("*.npz")) if (tmp_path / "sub").exists() else True


def test_bad_arguments_are_one_message(tmp_path, capsys):
    assert main(["genea", "submit", str(tmp_path / "nowhere"), "--out", str(tmp_path / "o"), "--samples", "0"]) == 2
    err = capsys.readouterr().err
    assert "--samples" in err and "nowhere" in err and "Traceback" not in err


def _npz(T=60, fps=30, **over):
    arrays = dict(poses=np.zeros((T, 165), np.float32), trans=np.zeros((T, 3), np.float32),
                  expressions=np.zeros((T, 100), np.float32), betas=np.zeros(300, np.float32),
                  gender=np.array("neutral"), mocap_frame_rate=np.array(fps))
    arrays.update(over)
    return arrays


def test_the_check_refuses_what_the_leaderboard_would_not_take():
    assert check_arrays("a", _npz(), 2.0) == []
    assert "expected 60" in check_arrays("a", _npz(T=50), 2.0)[0]
    assert "mocap_frame_rate" in check_arrays("a", _npz(fps=25), 2.0)[0]
    assert "'trans' has shape" in check_arrays("a", _npz(trans=np.zeros((60, 2))), 2.0)[0]
    nan = np.zeros((60, 165), np.float32)
    nan[3, 4] = np.nan
    assert "finite" in check_arrays("a", _npz(poses=nan), 2.0)[0]
    assert "no 'expressions'" in check_arrays("a", {k: v for k, v in _npz().items() if k != "expressions"}, 2.0)[0]

    def raw(arrays):
        buf = io.BytesIO()
        np.savez(buf, **arrays)
        return buf.getvalue()

    same = {"2_scott_0_2_2_sample1.npz": raw(_npz()), "2_scott_0_2_2_sample2.npz": raw(_npz())}
    assert any("same motion" in p for p in check_speech("2_scott_0_2_2", same, 2.0))


@pytest.mark.parametrize("name", ["2_scott_0_2_2", "10_kieks_0_65_65"])
def test_take_names_pass(name):
    from gesturelsm.genea.submission import check_name

    assert check_name(name) is None
