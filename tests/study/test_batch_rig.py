"""`gesturelsm batch --rig`: each blinded video shows the user's character (its own mesh) and gets the same motion
on the character beside it."""
from __future__ import annotations

import imageio_ffmpeg
import numpy as np
import pytest
import soundfile as sf

from _rigs import build_rig, vrm_body_bones
from _skinned import write_skinned_glb
from _support import speech_like
from gesturelsm.body.model import resolve_body
from gesturelsm.cli import main
from gesturelsm.export.glb import read_glb


@pytest.mark.slow                       # a whole command in subprocesses: the full tier
def test_batch_with_rig_draws_the_character_and_writes_its_file_per_video(tiny_assets, tmp_path, capsys):
    d = tmp_path / "speech"
    d.mkdir()
    sf.write(d / "alpha.wav", speech_like(1.0, seed=1), 16000)
    skel, _ = build_rig(resolve_body(None).rest_joints(), fingers=False)
    human = vrm_body_bones()
    write_skinned_glb(skel, tmp_path / "me.vrm", human, vrm="1", color=(0.05, 0.1, 0.6, 1.0), half=0.05)
    out = tmp_path / "study"
    assert main(["batch", "--audio-dir", str(d), "--methods", "gesturelsm", "ddim", "--out", str(out), "--raters",
                 "1", "--steps", "1", "--ddim-steps", "1", "--size", "128", "--checkpoints", str(tiny_assets),
                 "--rig", str(tmp_path / "me.vrm")]) == 0
    videos = sorted(p.stem for p in (out / "videos").glob("*.mp4"))
    rigs = sorted(p.stem for p in (out / "videos").glob("*.vrm"))
    assert len(videos) == 2 and rigs == videos
    for v in videos:
        gltf, _ = read_glb(out / "videos" / f"{v}.vrm")
        assert "VRMC_vrm" in gltf["extensions"] and gltf["animations"][0]["channels"]
        frames = imageio_ffmpeg.read_frames(str(out / "videos" / f"{v}.mp4"))
        next(frames)
        img = np.frombuffer(next(frames), np.uint8).reshape(128, 128, 3).astype(int)
        assert ((img[..., 2] - img[..., 0]) > 60).sum() > 100, "the character's blue boxes, not the clay mannequin"
    (tmp_path / "bad.vrm").write_text("{}")
    assert main(["batch", "--audio-dir", str(d), "--out", str(tmp_path / "o"), "--rig", str(tmp_path / "bad.vrm"),
                 "--checkpoints", str(tiny_assets)]) == 2
    assert "bad.vrm" in capsys.readouterr().err
