"""`gesturelsm batch --rig`: each blinded video gets the same motion on the user's character beside it."""
from __future__ import annotations

import soundfile as sf

from _rigs import build_rig, vrm_body_bones, write_gltf
from _support import speech_like
from gesturelsm.body.model import resolve_body
from gesturelsm.cli import main
from gesturelsm.export.glb import read_glb


def test_batch_with_rig_writes_a_character_file_per_video(tiny_assets, tmp_path, capsys):
    d = tmp_path / "speech"
    d.mkdir()
    sf.write(d / "alpha.wav", speech_like(1.0, seed=1), 16000)
    skel, _ = build_rig(resolve_body(None).rest_joints(), fingers=False)
    human = vrm_body_bones()
    write_gltf(skel, tmp_path / "me.vrm", human, vrm="1")
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
    (tmp_path / "bad.vrm").write_text("{}")
    assert main(["batch", "--audio-dir", str(d), "--out", str(tmp_path / "o"), "--rig", str(tmp_path / "bad.vrm"),
                 "--checkpoints", str(tiny_assets)]) == 2
    assert "bad.vrm" in capsys.readouterr().err
