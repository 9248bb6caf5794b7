"""A VRM's face follows the generated one: visemes from the mouth's opening and width measured on the body's
landmarks (a wider-open jaw raises `aa`, a closed neutral face gives 0, weights in [0, 1] summing to the
opening, the smile widens and its opposite rounds), no blink on the mannequin (its expressions have no
eyelid), and in the exported file weight channels on exactly the morph targets of the presets the character
defines."""
from __future__ import annotations

import json
import struct

import numpy as np
import pytest

from _rigs import build_rig, gltf_validator_errors, vrm_body_bones, write_gltf
from gesturelsm.body.model import resolve_body
from gesturelsm.export.alive import JAW_FULL, alive_face_weights
from gesturelsm.export.glb import accessor_array, read_glb
from gesturelsm.export.rig import export_rig_glb
from gesturelsm.motion import MotionSequence
from gesturelsm.motion.skeleton import JOINT_INDEX
from gesturelsm.retarget import load_character
from gesturelsm.retarget.face import PRESETS, VISEMES, WIDE_OPEN, face_weights
from _skinned import write_skinned_glb


def _vrm_with_mouth(tmp_path, version: str):
    skel, _ = build_rig(resolve_body(None).rest_joints(), fingers=False)
    human = vrm_body_bones()
    g = write_gltf(skel, tmp_path / "plain.vrm", human, vrm=version)
    blob = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 0], [0, 0.1, 0], [0, 0, 0]], np.float32).tobytes()
    g["buffers"] = [{"byteLength": len(blob)}]
    g["bufferViews"] = [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36,
                                                                           "byteLength": 36}]
    g["accessors"] = [{"bufferView": v, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0],
                       "max": hi} for v, hi in ((0, [1, 1, 0]), (1, [0, np.float32(0.1).item(), 0]))]
    g["meshes"] = [{"primitives": [{"attributes": {"POSITION": 0}, "targets": [{"POSITION": 1}]}], "weights": [0]}]
    g["nodes"].append({"name": "face", "mesh": 0})
    g["scenes"][0]["nodes"].append(len(g["nodes"]) - 1)
    if version == "1":
        g["extensions"]["VRMC_vrm"]["expressions"] = {"preset": {"aa": {"morphTargetBinds": [
            {"node": len(g["nodes"]) - 1, "index": 0, "weight": 1.0}]}}}
    else:
        g["extensions"]["VRM"]["blendShapeMaster"] = {"blendShapeGroups": [
            {"name": "A", "presetName": "a", "binds": [{"mesh": 0, "index": 0, "weight": 100}]}]}
    js = json.dumps(g).encode()
    js += b" " * (-len(js) % 4)
    path = tmp_path / "mouth.vrm"
    path.write_bytes(struct.pack("<4sII", b"glTF", 2, 28 + len(js) + len(blob)) + struct.pack("<I4s", len(js), b"JSON")
                     + js + struct.pack("<I4s", len(blob), b"BIN\0") + blob)
    return path, len(g["nodes"]) - 1


def test_mouth_opens_with_the_jaw(tmp_path):
    T = 40
    poses = np.zeros((T, 165), np.float32)
    poses[:, 3 * JOINT_INDEX["jaw"]] = np.linspace(-0.1, 0.5, T)            # closed (and beyond) to wide open
    seq = MotionSequence(poses, np.tile([0, 1.0, 0], (T, 1)), np.zeros((T, 100)))
    for version in ("1", "0"):
        path, face = _vrm_with_mouth(tmp_path, version)
        export_rig_glb(seq, load_character(path), tmp_path / f"out{version}.vrm")
        gltf, blob = read_glb(tmp_path / f"out{version}.vrm")
        anim = gltf["animations"][0]
        ch = [c for c in anim["channels"] if c["target"]["path"] == "weights"]
        assert [c["target"]["node"] for c in ch] == [face]
        w = accessor_array(gltf, blob, anim["samplers"][ch[0]["sampler"]]["output"])[:, 0]
        # the export's face is export/alive.py's: the mouth fully open at JAW_FULL (a face capture's scale)
        np.testing.assert_allclose(w, face_weights(resolve_body(None), poses, wide_open=JAW_FULL)["aa"], atol=1e-6)
        assert w[0] == 0.0 and w[-1] == 1.0 and np.all(np.diff(w) >= -1e-6)
        np.testing.assert_allclose(w[poses[:, 3 * JOINT_INDEX["jaw"]] >= JAW_FULL], 1.0, atol=1e-6)   # all `aa`
        np.testing.assert_allclose(accessor_array(gltf, blob, 1), [[0, 0, 0], [0, 0.1, 0], [0, 0, 0]])  # mesh kept
        report = gltf_validator_errors(tmp_path / f"out{version}.vrm", tmp_path)
        assert report is None or report[0] == 0, report                  # checked where node is installed


def _jaw(values, expressions=None):
    poses = np.zeros((len(values), 165))
    poses[:, 3 * JOINT_INDEX["jaw"]] = values
    return poses, (np.zeros((len(values), 100)) if expressions is None else expressions)


def test_a_wider_open_jaw_gives_a_larger_aa_and_a_closed_face_none(body):
    poses, ex = _jaw(np.linspace(0, WIDE_OPEN, 15))
    w = face_weights(body, poses, ex)
    assert set(w) == set(PRESETS)
    assert np.all(np.diff(w["aa"]) > 0) and w["aa"][-1] == pytest.approx(1.0, abs=1e-6)
    for p in PRESETS:
        assert w[p][0] == pytest.approx(0.0, abs=1e-6), p                   # closed, neutral: nothing
        assert np.all((w[p] >= 0) & (w[p] <= 1)), p
    total = sum(w[p] for p in VISEMES)
    assert np.all(np.diff(total) > 0) and np.all(total <= 1 + 1e-9)


def test_the_lips_width_chooses_between_wide_and_round_visemes(body):
    """Mannequin expression 1 is a smile (corners out): + widens the mouth (ee / ih), - narrows it (oh / ou)."""
    ex = np.zeros((3, 100))
    ex[:, 1] = [-3.0, 0.0, 3.0]
    w = face_weights(body, *_jaw([0.25] * 3, ex))
    assert w["oh"][0] > 0.05 and w["ou"][0] > 0.05 and w["ee"][0] == w["oh"][2] == 0.0
    assert w["ee"][2] > 0.05 and w["ee"][1] == w["oh"][1] == w["ou"][1] == 0.0
    assert w["aa"][1] > max(w["aa"][0], w["aa"][2])                          # the neutral width is `aa`'s
    opening = sum(w[p] for p in VISEMES)
    assert np.all((opening > 0.3) & (opening <= 1.0))                        # the width shares the opening out


def test_no_blink_without_eyelid_motion(body):
    rng = np.random.default_rng(0)
    poses, _ = _jaw(rng.uniform(0, 0.3, 20))
    w = face_weights(body, poses, rng.normal(size=(20, 100)))
    assert np.all(w["blink"] == 0.0)


def test_only_the_presets_a_character_defines_get_weights(tmp_path, body):
    skel, _ = build_rig(body.rest_joints(), fingers=False)
    T = 30
    rng = np.random.default_rng(1)
    poses, ex = _jaw(np.linspace(0, 0.4, T), rng.normal(size=(T, 100)))
    seq = MotionSequence(poses, np.tile([0, 1.0, 0], (T, 1)), ex)
    expected = alive_face_weights(body, seq)                                # what exports show (export/alive.py)
    for version in ("1", "0"):
        path = tmp_path / f"oh_aa{version}.vrm"
        write_skinned_glb(skel, path, vrm_body_bones(), vrm=version, presets=("oh", "aa"))
        export_rig_glb(seq, load_character(path), tmp_path / f"out{version}.vrm")
        gltf, blob = read_glb(tmp_path / f"out{version}.vrm")
        anim = gltf["animations"][0]
        (ch,) = [c for c in anim["channels"] if c["target"]["path"] == "weights"]
        assert gltf["nodes"][ch["target"]["node"]].get("mesh") == 0
        W = accessor_array(gltf, blob, anim["samplers"][ch["sampler"]]["output"]).reshape(T, 2)
        np.testing.assert_allclose(W, np.stack([expected["oh"], expected["aa"]], 1), atol=1e-6)
        report = gltf_validator_errors(tmp_path / f"out{version}.vrm", tmp_path)
        assert report is None or report[0] == 0, report
    plain = tmp_path / "plain.vrm"
    write_skinned_glb(skel, plain, vrm_body_bones())                         # no expressions at all
    export_rig_glb(seq, load_character(plain), tmp_path / "out_plain.vrm")
    gltf, _ = read_glb(tmp_path / "out_plain.vrm")
    assert not [c for c in gltf["animations"][0]["channels"] if c["target"]["path"] == "weights"]
