"""The page's mp4 renders in a process of its own (render/background.py): a new session (its own autogroup, so a
browser in another session is not shared fairly with it) at lowered priority, rendering exactly what render_video
renders in-process, with progress, errors and cleanup coming back to the caller."""
from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gesturelsm.errors import RenderError
from gesturelsm.render import RenderWarning, render_video
from gesturelsm.render.background import read_autogroup, render_apart

from .test_video import decode_audio, decode_video, step_clip

linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="sessions, niceness and autogroups are Linux's")
AUTOGROUPS = Path("/proc/sys/kernel/sched_autogroup_enabled")


@linux
def test_a_new_session_lowers_its_own_priority_and_its_autogroup():
    code = "import json; from gesturelsm.render.background import lower_this_process as f; print(json.dumps(f(7)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         start_new_session=True).stdout
    info = json.loads(out.strip().splitlines()[-1])
    assert info["sid"] == info["pid"] != os.getsid(0)                  # a session of its own
    assert info["nice"] == min(19, os.getpriority(os.PRIO_PROCESS, 0) + 7)
    mine, theirs = read_autogroup(), info["autogroup"]
    if AUTOGROUPS.exists() and AUTOGROUPS.read_text().strip() == "1":
        # Some sandboxes show no autogroup for this process (the file reads empty) yet one for a new session's.
        if mine is not None:
            assert theirs is not None and theirs.split()[0] != mine.split()[0]
        if theirs is not None:
            assert theirs.endswith("nice 7")
    else:
        assert theirs in (None, mine)


def test_an_unreadable_or_empty_autogroup_reads_as_none(tmp_path, monkeypatch):
    import gesturelsm.render.background as bg
    for text, want in [("/autogroup-12 nice 3\n", "/autogroup-12 nice 3"), ("", None), ("garbage", None)]:
        (tmp_path / "ag").write_text(text)
        monkeypatch.setattr(bg, "AUTOGROUP", tmp_path / "ag")
        assert read_autogroup() == want
    monkeypatch.setattr(bg, "AUTOGROUP", tmp_path / "missing")
    assert read_autogroup() is None
    assert bg.lower_this_process(0)["autogroup"] is None


@pytest.mark.slow                       # a whole command in subprocesses: the full tier
@linux
def test_render_apart_equals_render_video_in_a_lowered_session(tmp_path, make_pose, caplog):
    motion, y = step_clip(make_pose, frames=40, step=25)
    other = make_pose(40, 0.3, x=0.2)
    kw = {"labels": ["GestureLSM 8 steps", "DDIM 20"], "gen_seconds": [0.41, None], "size": (64, 64)}
    seen = []
    with caplog.at_level(logging.INFO, logger="gesturelsm.render.background"), \
            pytest.warns(RenderWarning, match="audio trimmed"):        # the renderer's notes come back as warnings
        out = render_apart([motion, other], y, tmp_path / "req" / "apart.mp4", progress=lambda f, m: seen.append(f),
                           nice=5, **kw)
    with pytest.warns(RenderWarning, match="audio trimmed"):
        ref = render_video([motion, other], y, tmp_path / "inproc.mp4", **kw)
    a, b = decode_video(out, (128, 64)), decode_video(ref, (128, 64))
    assert a.shape == b.shape == (40, 64, 128, 3)
    diff = np.abs(a.astype(int) - b.astype(int))
    assert diff.mean() < 0.3 and np.percentile(diff, 99.9) <= 8, "the same frames, labels included (x264 noise only)"
    assert np.allclose(decode_audio(out), decode_audio(ref), atol=1e-3)
    assert seen and seen[-1] == 1.0 and all(p <= q for p, q in zip(seen, seen[1:]))
    assert [p.name for p in out.parent.iterdir()] == ["apart.mp4"], "the job's files are removed"
    info = next(r.args for r in caplog.records if r.msg.startswith("rendering in process"))
    assert info["sid"] != os.getsid(0) and info["pid"] != os.getpid()
    assert info["nice"] == min(19, os.getpriority(os.PRIO_PROCESS, 0) + 5)


@pytest.mark.slow                       # a whole command in subprocesses: the full tier
@linux
def test_render_apart_draws_the_character_given(tmp_path, make_pose, body):
    """The page's mp4 with a character: the render process draws its mesh (`--rig`), as render_video does."""
    from _rigs import build_rig, vrm_body_bones
    from _skinned import write_skinned_glb
    from gesturelsm.retarget import load_character

    skel, _ = build_rig(body.rest_joints(), fingers=False)
    write_skinned_glb(skel, tmp_path / "boxes.vrm", vrm_body_bones(), color=(0.05, 0.1, 0.6, 1.0), half=0.05)
    motion = make_pose(12, np.linspace(-1.2, 1.2, 12))
    out = render_apart([motion], None, tmp_path / "req" / "apart.mp4", size=(64, 64), nice=5,
                       rig=tmp_path / "boxes.vrm")
    ref = render_video([motion], None, tmp_path / "inproc.mp4", size=(64, 64),
                       character=load_character(tmp_path / "boxes.vrm"))
    plain = render_video([motion], None, tmp_path / "mannequin.mp4", size=(64, 64))
    a, b, c = (decode_video(p, (64, 64)).astype(int) for p in (out, ref, plain))
    assert np.abs(a - b).mean() < 0.3 and np.abs(a - c).mean() > 2, "the character, not the mannequin"


def test_a_failing_render_says_why_and_leaves_nothing(tmp_path, make_pose):
    missing = tmp_path / "nowhere" / "SMPLX_NEUTRAL.npz"
    with pytest.raises(RenderError, match="nowhere"):
        render_apart([make_pose(5, -1.2)], None, tmp_path / "out" / "v.mp4", size=(64, 64), body_path=missing)
    assert list((tmp_path / "out").iterdir()) == []
