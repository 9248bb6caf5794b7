"""A study video as a unit of work (gesturelsm/study/videos.py): its motion does not depend on where it is made."""
from __future__ import annotations

import io

import numpy as np
import pytest

from gesturelsm.constants import ASSETS
from gesturelsm.pipeline import Plan
from gesturelsm.settings import Settings
from gesturelsm.study.videos import VideoSpec, VideoUnit, build, make_video

from _support import speech_like


@pytest.mark.slow                        # loads the shipped network
def test_a_units_motion_is_the_same_bytes_whatever_this_process_threads_or_kernels(monkeypatch):
    """The shipped network's sums come out in another order with two math threads than with one (a Ray worker of
    one CPU has one), and with the fast kernels a process chose by timing than without: a unit pins one thread and
    the default kernels, so the motion made here and on a worker is the same file."""
    import os

    import torch

    if not (ASSETS / "generator" / "gesturelsm.safetensors").exists():
        pytest.skip(f"shipped generator checkpoints not found in {ASSETS / 'generator'}")
    built = build(VideoSpec((), ("gesturelsm",), None, None, 128))
    unit = VideoUnit("v_0123456789.mp4", "a.wav", "gesturelsm", Plan(Settings(("gesturelsm",), {"gesturelsm": 4})),
                     speech_like(2.0, seed=1), render=False)
    before = torch.get_num_threads()
    got = []
    try:
        for threads, kernels in ((2, "all"), (1, None), (2, "linear,trace")):
            torch.set_num_threads(threads)
            if kernels is None:
                monkeypatch.delenv("GESTURELSM_KERNELS", raising=False)
            else:
                monkeypatch.setenv("GESTURELSM_KERNELS", kernels)
            files = make_video(built, unit)
            assert os.environ.get("GESTURELSM_KERNELS") == kernels and torch.get_num_threads() == threads
            assert files.video is None and files.rig is None
            got.append(files.motion)
    finally:
        torch.set_num_threads(before)
    assert got[0] == got[1] == got[2] and len(got[0]) > 30 * 165 * 4
    assert torch.get_num_threads() == before
    with np.load(io.BytesIO(got[0])) as d:
        assert d["poses"].shape == (60, 165)


@pytest.mark.slow                        # two batches over checkpoints
def test_a_missing_motion_is_made_again_without_the_video(tiny_assets, tmp_path):
    import soundfile as sf

    from gesturelsm.pipeline import GesturePipeline
    from gesturelsm.settings import Settings
    from gesturelsm.study import make_study

    speech = tmp_path / "speech"
    speech.mkdir()
    for i, name in enumerate(("a.wav", "b.wav")):
        sf.write(speech / name, speech_like(1.0, seed=i), 16000)
    pipe = GesturePipeline.from_pretrained(tiny_assets)
    out = tmp_path / "study"
    settings = Settings(("gesturelsm", "ddim"), {"gesturelsm": 1, "ddim": 1})
    kw = dict(raters=1, size=128, log=lambda m: None)
    make_study(pipe, speech, out, settings, **kw)
    motions = {p.name: p.read_bytes() for p in (out / "key" / "motion").iterdir()}
    videos = {p.name: p.stat().st_mtime_ns for p in (out / "videos").glob("v_*.mp4")}
    assert len(motions) == 4 and {n[:-4] for n in motions} <= {n[:-4] for n in videos}
    gone = sorted(motions)[0]
    (out / "key" / "motion" / gone).unlink()
    logs = []
    make_study(pipe, speech, out, settings, **dict(kw, log=logs.append))
    assert "0 videos rendered, 3 already there" in logs[-1]
    assert {p.name: p.read_bytes() for p in (out / "key" / "motion").iterdir()} == motions   # the same bytes again
    assert {p.name: p.stat().st_mtime_ns for p in (out / "videos").glob("v_*.mp4")} == videos  # no video touched
