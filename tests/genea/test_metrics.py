"""`gesturelsm genea metrics` against an independent implementation of the leaderboard's definitions (written here
from exp_eval_metrics.py's: numpy / scipy, sqrtm of the covariance product as the reference takes it)."""
from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import linalg

from gesturelsm.cli import main

TAKES = ("2_scott_0_2_2", "2_scott_0_3_3", "2_scott_0_4_4")


def _smooth(rng, T, scale):
    x = np.cumsum(rng.normal(0, scale, (T, 165)), axis=0)
    return (x - x.mean(0)) * 0.05 + rng.normal(0, 0.3, 165)


def _write(path, poses):
    T = len(poses)
    np.savez(path, poses=poses.astype(np.float32), trans=np.zeros((T, 3), np.float32),
             expressions=np.zeros((T, 100), np.float32), betas=np.zeros(300, np.float32), gender=np.array("neutral"),
             mocap_frame_rate=np.array(30))


@pytest.fixture
def folders(tmp_path):
    rng = np.random.default_rng(3)
    human, gen = tmp_path / "human", tmp_path / "gen"
    human.mkdir()
    gen.mkdir()
    for i, take in enumerate(TAKES):
        _write(human / f"{take}.npz", _smooth(rng, 400 + 37 * i, 0.3))
        for k in range(1, 4):
            _write(gen / f"{take}_sample{k}.npz", _smooth(rng, 390 + 41 * i + 3 * k, 0.4))
    return gen, human


def _load(path):
    return np.nan_to_num(np.load(path)["poses"].astype(np.float64))


def _fd(a, b):
    mu1, mu2 = a.mean(0), b.mean(0)
    s1, s2 = np.cov(a, rowvar=False), np.cov(b, rowvar=False)
    covmean = linalg.sqrtm(s1.dot(s2)).real
    return (mu1 - mu2) @ (mu1 - mu2) + np.trace(s1) + np.trace(s2) - 2 * np.trace(covmean)


def reference(gen, human):
    hs = [_load(f) for f in sorted(human.glob("*.npz"))]
    groups = {t: [_load(f) for f in sorted(gen.glob(f"{t}_*.npz"))] for t in TAKES}
    gs = [g for t in TAKES for g in groups[t]]
    fid_g = _fd(np.concatenate(hs), np.concatenate(gs))
    fid_k = _fd(np.concatenate([h[1:] - h[:-1] for h in hs]), np.concatenate([g[1:] - g[:-1] for g in gs]))
    var_k = np.concatenate([np.var(g, axis=0) for g in gs]).mean()
    divs = []
    for samples in groups.values():
        n = min(len(s) for s in samples)
        divs.append(np.var(np.stack([s[:n] for s in samples]).reshape(len(samples), -1), axis=0).mean())
    return dict(fid_g=fid_g, fid_k=fid_k, var_k=var_k, sample_div=float(np.mean(divs)))


def test_metrics_agree_with_an_independent_implementation(folders, tmp_path, capsys):
    gen, human = folders
    out = tmp_path / "m.json"
    assert main(["genea", "metrics", str(gen), str(human), "--json", str(out)]) == 0
    got = json.loads(out.read_text())
    assert set(got) >= {"fgd", "fid_g", "fid_k", "bc_m2a", "bc_a2m", "srgr", "div", "var_k", "sample_div"}
    want = reference(gen, human)
    for key, value in want.items():
        assert got[key] == pytest.approx(value, rel=1e-3), key
    assert got["fgd"] is None and got["bc_m2a"] is None and got["srgr"] is None
    assert got["div"] > 0
    text = capsys.readouterr().out
    assert "FGD left out" in text and "| FD_g | FD_k |" in text and "9 samples of 3 takes" in text


def test_takes_that_differ_are_one_line(folders, capsys):
    gen, human = folders
    (human / f"{TAKES[0]}.npz").unlink()
    assert main(["genea", "metrics", str(gen), str(human)]) == 2
    err = capsys.readouterr().err
    assert "no human motion" in err and TAKES[0] in err and "Traceback" not in err


def test_one_sample_per_take_leaves_sample_div_out(folders, tmp_path, capsys):
    gen, human = folders
    for f in gen.glob("*_sample[23].npz"):
        f.unlink()
    out = tmp_path / "m.json"
    assert main(["genea", "metrics", str(gen), str(human), "--json", str(out)]) == 0
    assert json.loads(out.read_text())["sample_div"] is None
    assert "DIV_sample left out" in capsys.readouterr().out


def test_beat_alignment_and_srgr_run_with_speech_and_labels(folders, tmp_path):
    import soundfile as sf

    from _support import speech_like

    gen, human = folders
    audio, sem = tmp_path / "audio", tmp_path / "sem"
    audio.mkdir()
    sem.mkdir()
    for i, take in enumerate(TAKES):
        sf.write(audio / f"{take}.wav", speech_like(15.0, seed=i), 16000)
        (sem / f"{take}.txt").write_text("beat\t1.0\t4.0\t3.0\t0.5\t\ndeictic\t6.0\t8.5\t2.5\t0.8\t\n")
    speed = tmp_path / "mean_vel_smplxflame_30.npy"
    np.save(speed, np.full(55, 0.05))
    out = tmp_path / "m.json"
    assert main(["genea", "metrics", str(gen), str(human), "--audio", str(audio), "--sem", str(sem),
                 "--mean-speed", str(speed), "--json", str(out)]) == 0
    got = json.loads(out.read_text())
    assert 0 <= got["bc_a2m"] <= 1 and 0 <= got["bc_m2a"] <= 1
    assert got["srgr"] is not None and got["srgr"] >= 0


def test_fgd_weights_that_are_missing_are_refused(folders, tmp_path, capsys):
    gen, human = folders
    assert main(["genea", "metrics", str(gen), str(human), "--fgd-weights", str(tmp_path)]) == 2
    assert "AESKConv_240_100.bin" in capsys.readouterr().err


def test_fgd_with_emage_weights_is_zero_against_itself(tmp_path):
    import torch

    from gesturelsm.metrics.emage_fgd import SkeletonConvEncoder

    rng = np.random.default_rng(5)
    human, gen = tmp_path / "human", tmp_path / "gen"
    human.mkdir()
    gen.mkdir()
    for i, take in enumerate(TAKES):
        poses = _smooth(rng, 160, 0.3)
        _write(human / f"{take}.npz", poses)
        _write(gen / f"{take}_sample1.npz", poses)
    torch.manual_seed(0)
    state = {f"encoder.{k}": v for k, v in SkeletonConvEncoder().state_dict().items()}
    torch.save({"model_state": state}, tmp_path / "AESKConv_240_100.bin")
    out = tmp_path / "m.json"
    assert main(["genea", "metrics", str(gen), str(human), "--fgd-weights", str(tmp_path), "--json", str(out)]) == 0
    got = json.loads(out.read_text())
    assert got["fgd"] == pytest.approx(0.0, abs=1e-3)
    assert got["fid_g"] == pytest.approx(0.0, abs=1e-6)
