"""A VRM's mouth follows the generated jaw: the `aa` expression's morph targets get weight channels in the
exported file, 0 with the jaw closed and 1 at 0.35 rad of opening, on the mesh nodes the expression binds."""
from __future__ import annotations

import json
import struct

import numpy as np

from _rigs import build_rig, gltf_validator_errors, vrm_body_bones, write_gltf
from gesturelsm.body.model import resolve_body
from gesturelsm.export.glb import accessor_array, read_glb
from gesturelsm.export.rig import export_rig_glb
from gesturelsm.motion import MotionSequence
from gesturelsm.motion.skeleton import JOINT_INDEX
from gesturelsm.retarget import load_character
from gesturelsm.retarget.face import jaw_open


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
        np.testing.assert_allclose(w, jaw_open(poses), atol=1e-6)
        assert w[0] == 0.0 and w[-1] == 1.0 and np.all(np.diff(w) >= 0)
        np.testing.assert_allclose(accessor_array(gltf, blob, 1), [[0, 0, 0], [0, 0.1, 0], [0, 0, 0]])  # mesh kept
        report = gltf_validator_errors(tmp_path / f"out{version}.vrm", tmp_path)
        assert report is None or report[0] == 0, report                  # checked where node is installed
