"""`gesturelsm export --rig`: the character's own GLB / VRM with the motion, and its skeleton's BVH.

The GLB's animation, read back, is the retargeted local rotations; the BVH, read back and posed, puts every
bone where the retargeting did; the file passes the Khronos glTF validator (node + npm gltf-validator) and
loads as a VRM in three-vrm in Chromium, where the right wrist sits where the motion says."""
from __future__ import annotations

import base64

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from _rigs import bvh_positions, character_js_page, gltf_validator_errors
from gesturelsm.cli import main
from gesturelsm.export.glb import accessor_array, read_glb
from gesturelsm.retarget import load_character, retarget_motion
from _support import VRM



@pytest.fixture(scope="module")
def character():
    if not VRM.exists():
        pytest.skip(f"the shared character is not at {VRM} (../shared beside the repo)")
    return load_character(VRM)


@pytest.fixture(scope="module")
def exported(character, real_motion, tmp_path_factory):
    seq = real_motion.slice(0, 90)
    out = tmp_path_factory.mktemp("rig")
    seq.save(out / "take.npz")
    assert main(["export", str(out / "take.npz"), "--rig", str(VRM), "--glb", str(out / "take.vrm"),
                 "--bvh", str(out / "take.bvh")]) == 0
    return seq, retarget_motion(seq, character), out


def test_glb_keeps_the_vrm_and_carries_the_rotations(exported, character):
    seq, result, out = exported
    gltf, blob = read_glb(out / "take.vrm")
    original = character.document.gltf
    assert gltf["extensions"]["VRM"] == original["extensions"]["VRM"]
    assert len(gltf["nodes"]) == len(original["nodes"]) and gltf["skins"] == original["skins"]
    anim = gltf["animations"][0]
    assert anim["name"] == "gesturelsm"
    skel = result.skeleton
    by_node = {skel.nodes[i]: i for i in range(len(skel))}
    rotated = 0
    for ch in anim["channels"]:
        sampler = anim["samplers"][ch["sampler"]]
        data = accessor_array(gltf, blob, sampler["output"])
        i = by_node[ch["target"]["node"]]
        if ch["target"]["path"] == "rotation":
            got = Rotation.from_quat(data).as_matrix()
            np.testing.assert_allclose(got, result.local_rotation[:, i], atol=1e-5)
            rotated += 1
        else:
            np.testing.assert_allclose(data, result.root_translation, atol=1e-5)
    assert rotated == len(skel.bones) == 43
    times = accessor_array(gltf, blob, anim["samplers"][0]["input"])[:, 0]
    np.testing.assert_allclose(times, np.arange(seq.num_frames) / 30, atol=1e-6)


def test_bvh_poses_the_skeleton_as_retargeted(exported):
    seq, result, out = exported
    names, P = bvh_positions(out / "take.bvh")
    skel = result.skeleton
    for name in ("Left wrist", "Right wrist", "Head", "Left ankle", "Right toe"):
        i = skel.names.index(name)
        np.testing.assert_allclose(P[:, names.index(name.replace(" ", "_"))], result.positions[:, i], atol=1e-4)


def test_glb_passes_the_khronos_validator(exported, tmp_path):
    _, _, out = exported
    report = gltf_validator_errors(out / "take.vrm", tmp_path)
    if report is None:
        pytest.skip("node or npm gltf-validator is not installed (cd gesturelsm/webapp/player && npm ci)")
    assert report[0] == 0, report[1]


@pytest.mark.browser
def test_three_vrm_loads_it_and_the_wrist_moves_as_the_motion_says(exported, tmp_path):
    seq, result, out = exported
    data = base64.b64encode((out / "take.vrm").read_bytes()).decode()
    frames = [0, 45, 89]
    with character_js_page(tmp_path) as page:
        got = page.evaluate("""async ([b64, times]) => {
            const bytes = Uint8Array.from(atob(b64), c => c.charCodeAt(0)).buffer;
            const ch = await window.C.loadCharacter(bytes);
            const out = {vrm: !!ch.vrm, version: ch.vrm ? ch.vrm.meta.metaVersion : null,
                         clip: ch.clip ? ch.clip.name : null, wrist: []};
            for (const t of times) {
                window.C.seek(ch, t);
                out.wrist.push(window.C.boneWorldPosition(ch, 'rightHand'));
            }
            return out;
        }""", [data, [f / 30 for f in frames]])
    assert got["vrm"] and got["version"] == "0" and got["clip"] == "gesturelsm"
    wrist = result.skeleton.bones["right_wrist"]
    want = result.positions[frames, wrist]
    assert np.linalg.norm(want[1] - want[0]) > 0.02                         # the wrist does move in the take
    np.testing.assert_allclose(np.asarray(got["wrist"]), want, atol=1e-3)
