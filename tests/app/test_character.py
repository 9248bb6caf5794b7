"""The page's character, server side (gesturelsm/webapp/character.py) and in the browser (app/player/src/character.js):
the payload carries the retargeted rotations exactly; bad uploads give one-line gr.Errors; three-vrm posed
from the payload puts the right wrist where the retargeting does."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import gradio as gr
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from _rigs import bundle_character_js
from gesturelsm.webapp.character import character_payload, decode, read_upload
from gesturelsm.retarget import retarget_motion

VRM = Path(__file__).resolve().parents[2].parent / "shared" / "assets" / "characters" / "cryptovoxels.vrm"
CHROMIUM = next((p for p in ("/usr/lib/chromium/chromium", "/usr/bin/chromium", shutil.which("chromium") or "")
                 if p and Path(p).exists()), None)


@pytest.fixture(scope="module")
def character():
    if not VRM.exists():
        pytest.skip(f"the shared character is not at {VRM} (../shared beside the repo)")
    return read_upload(str(VRM))


@pytest.fixture(scope="module")
def payload(character, real_motion):
    motions = {"gesturelsm": real_motion.slice(0, 60), "ddim": real_motion.slice(200, 260)}
    return motions, character_payload(character, motions)


def test_payload_carries_the_retargeted_rotations(character, payload):
    motions, p = payload
    assert p["name"] == "cryptovoxels.vrm" and p["frames"] == 60 and p["fps"] == 30
    skel = character.skeleton
    assert p["nodes"][0] == skel.nodes[skel.bones["pelvis"]] and len(p["nodes"]) == len(skel.bones) == 43
    by_node = {skel.nodes[i]: i for i in range(len(skel))}
    for method, seq in motions.items():
        r = retarget_motion(seq, character)
        q = decode(p["methods"][method]["quats"], (60, 43, 4))
        got = Rotation.from_quat(q.reshape(-1, 4)).as_matrix().reshape(60, 43, 3, 3)
        want = r.local_rotation[:, [by_node[n] for n in p["nodes"]]]
        np.testing.assert_allclose(got, want, atol=1e-5)
        np.testing.assert_allclose(decode(p["methods"][method]["root"], (60, 3)), r.root_translation, atol=1e-5)
    json.dumps(p)                                                    # goes to the page as JSON


def test_bad_uploads_are_one_line_errors(tmp_path):
    assert read_upload(None) is None
    (tmp_path / "me.fbx").write_bytes(b"Kaydara FBX Binary")
    (tmp_path / "me.vrm").write_bytes(b"\x00" * 100)
    (tmp_path / "me.bvh").write_text("HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\n}\nMOTION\n")
    for name, msg in (("me.fbx", "must be a .vrm, .glb or .gltf"), ("me.vrm", "not a glTF / VRM file"),
                      ("me.bvh", "must be a .vrm")):
        with pytest.raises(gr.Error, match=msg) as info:
            read_upload(str(tmp_path / name))
        assert "\n" not in str(info.value)


@pytest.mark.browser
@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (scripts/setup.sh installs it)")
def test_three_vrm_posed_from_the_payload_matches(character, payload, real_motion, tmp_path):
    bundle = bundle_character_js(tmp_path)
    if bundle is None:
        pytest.skip("the player's npm packages are not installed (cd app/player && npm ci)")
    from playwright.sync_api import sync_playwright

    import base64

    motions, p = payload
    frames = [0, 30, 59]
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        page = browser.new_page()
        page.set_content("<html><body></body></html>")
        page.add_script_tag(content=bundle.read_text())
        got = page.evaluate("""async ([b64, payload, frames]) => {
            const bytes = Uint8Array.from(atob(b64), c => c.charCodeAt(0)).buffer;
            const ch = await window.C.loadCharacter(bytes);
            const out = [];
            for (const f of frames) {
                window.C.showPayloadFrame(ch, payload, 'ddim', f);
                out.push(window.C.boneWorldPosition(ch, 'rightHand'));
            }
            return out;
        }""", [base64.b64encode(VRM.read_bytes()).decode(), p, frames])
        browser.close()
    r = retarget_motion(motions["ddim"], character)
    want = r.positions[frames, r.skeleton.bones["right_wrist"]]
    np.testing.assert_allclose(np.asarray(got), want, atol=1e-3)
