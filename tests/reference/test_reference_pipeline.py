"""The authors' methods through our pipeline: beside ours, any length, neutral face, stated in warnings."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from _support import speech_like
from gesturelsm.pipeline import ASSETS, GesturePipeline, InputError
from gesturelsm.reference.config import REGION_DIMS, RVQConfig
from gesturelsm.reference.rvq import ReferenceRVQ
from gesturelsm.reference.runner import FACE_NOTE, ReferenceBundle

FIX = Path(__file__).parent / "fixtures"


@pytest.fixture(scope="module")
def pipe(ckpt_dir) -> GesturePipeline:
    return GesturePipeline.from_pretrained(checkpoints=[ASSETS, ckpt_dir], warm_up=False)


def test_authors_methods_offered_beside_ours(pipe):
    assert {"gesturelsm_authors", "meanflow_authors"} <= set(pipe.methods)
    assert "gesturelsm" in pipe.methods           # the shipped models stay available
    with pytest.raises(InputError, match=r"Steps for MeanFlow \(authors' weights\) must be from 1 to 128"):
        pipe.generate(speech_like(1.0), steps=0, method="meanflow_authors", output="raw")


def test_long_speech_any_length_neutral_face(pipe):
    """64 s (their code stops at 63 s): every frame generated, jaw identity and expressions zero, said so. Audio
    only (no automatic transcription: the point is the length, and Whisper spends ~40 s on 64 s of tones)."""
    y = speech_like(64.0)
    res = pipe.generate(y, 16000, steps=1, cfg=1.0, seed=0, method="meanflow_authors", transcribe=False, output="raw")
    assert res.motion.num_frames == 64 * 30
    assert np.allclose(res.motion.poses[:, 66:69], 0, atol=1e-5) and np.allclose(res.motion.expressions, 0)
    assert FACE_NOTE in res.warnings and any("any length" in w for w in res.warnings)
    tail = res.motion.poses[-300:, 3 * 16:3 * 22]            # arms move in the last 10 s too
    assert tail.std(axis=0).max() > 1e-4


def test_same_seed_same_motion_and_seed_matters(pipe):
    y = speech_like(6.0)
    kw = {"steps": 2, "cfg": 2.0, "method": "gesturelsm_authors", "transcribe": False}
    a = pipe.generate(y, 16000, seed=3, **kw, output="raw").motion.poses
    b = pipe.generate(y, 16000, seed=3, **kw, output="raw").motion.poses
    c = pipe.generate(y, 16000, seed=4, **kw, output="raw").motion.poses
    assert np.array_equal(a, b) and not np.allclose(a, c)


def test_neutral_seed_is_the_mean_pose_encoding():
    """The first window's seed encodes the mean pose standing still: decoding it gives back ~that pose."""
    torch.manual_seed(0)
    rvqs = {r: ReferenceRVQ(RVQConfig(input_dim=n, width=8, code_dim=8,
                                      num_codes=16)).eval() for r, n in REGION_DIMS.items()}
    stats = {"mean": torch.zeros(330), "std": torch.ones(330), "trans_mean": torch.tensor([0.5, 1.0, -0.5]),
             "trans_std": torch.ones(3)}
    seed = ReferenceBundle(rvqs, stats).neutral_seed(4)
    assert seed.shape == (1, 4, 24)
    x = torch.zeros(1, 128, 57)
    x[..., -3], x[..., -1] = -0.5, 0.5
    z = rvqs["lower"].encode(x)
    assert torch.allclose(seed[..., 16:] * 5, z[:, 14:18])


def test_cli_generate_with_authors_method(ckpt_dir, tmp_path, capsys):
    from gesturelsm.cli import main
    from gesturelsm.motion import MotionSequence

    out = tmp_path / "m.npz"
    assert main(["generate", str(FIX / "speech.wav"), "--method", "meanflow_authors", "--cfg", "1",
                 "--checkpoints", str(ckpt_dir), "--out", str(out)]) == 0
    assert MotionSequence.load(out).num_frames == 30
    assert "face neutral" in capsys.readouterr().out
