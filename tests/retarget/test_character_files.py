"""Characters read from files (glTF / VRM 0.x / VRM 1.0 / BVH, name presets, JSON maps) retarget as the
skeletons they describe; files that cannot be used get one clear line (CharacterError, an InputError)."""
from __future__ import annotations

import json
import struct

import numpy as np
import pytest

from _rigs import Y_UP_TO_Z_UP, build_rig, direction_errors, write_gltf
from gesturelsm.cli import main
from gesturelsm.errors import InputError
from gesturelsm.retarget import CharacterError, load_character, retarget
from gesturelsm.retarget.names import MIXAMO, VRM_BONES
from gesturelsm.retarget.names import VRM0_THUMB, VRM1_THUMB


@pytest.fixture(scope="module")
def take(real_motion):
    return real_motion.slice(0, 120)


def _vrm_names(skel, thumb: tuple[str, ...]) -> dict[str, str]:
    """VRM humanoid bone -> joint name for a Mixamo-named built rig."""
    to_smplx = {v: k for k, v in MIXAMO.items()}
    by_joint = {to_smplx[n]: n for n in skel.names if n in to_smplx}
    out = {b: by_joint[j] for b, j in VRM_BONES.items() if j in by_joint}
    for s in ("left", "right"):
        for k, seg in enumerate(thumb, 1):
            if f"{s}_thumb{k}" in by_joint:
                out[f"{s}Thumb{seg}"] = by_joint[f"{s}_thumb{k}"]
    out.update({"spine": by_joint["spine1"], "chest": by_joint["spine2"], "upperChest": by_joint["spine3"]})
    return out


@pytest.mark.parametrize("vrm", ["0", "1", None])
def test_gltf_files_retarget_like_their_skeletons(vrm, tmp_path, take, source, smplx_joints):
    """A Z-up centimetre rig with random local axes, saved as VRM 1.0 / 0.x (opaque node names, found by the
    humanoid map) or plain glTF (mixamorig: names, found by the preset)."""
    skel, to_smplx = build_rig(source.rest_joints, apose=35.0, axes=True, world=Y_UP_TO_Z_UP, units=100.0, seed=3)
    if vrm:
        thumb = VRM1_THUMB if vrm == "1" else VRM0_THUMB
        human = {b: f"bone_{skel.names.index(n):02d}" for b, n in _vrm_names(skel, thumb).items()}
        names = [f"bone_{i:02d}" for i in range(len(skel))]
        write_gltf(skel, tmp_path / "c.vrm", human, vrm=vrm, names=names)
        path = tmp_path / "c.vrm"
    else:
        write_gltf(skel, tmp_path / "c.glb", names=[f"mixamorig:{n}" for n in skel.names])
        path = tmp_path / "c.glb"
    character = load_character(path)
    assert character.skeleton.kind == (f"vrm{vrm}" if vrm else "gltf")
    np.testing.assert_allclose(character.skeleton.world()[:, :3, 3], skel.world()[:, :3, 3], atol=1e-4)
    assert len(character.skeleton.bones) == 52                 # 55 SMPL-X joints less the jaw and eyes
    err = direction_errors(retarget(take, character.skeleton, source), to_smplx, smplx_joints)
    assert err.mean() < 2.0 and np.percentile(err, 95) < 5.0


def test_json_bone_map_names_any_rig(tmp_path, take, source, smplx_joints):
    skel, to_smplx = build_rig(source.rest_joints, fingers=False)
    names = [f"b{i}" for i in range(len(skel))]
    to_smplx_name = {v: k for k, v in MIXAMO.items()}
    mapping = {to_smplx_name[n]: names[i] for i, n in enumerate(skel.names)}
    write_gltf(skel, tmp_path / "c.glb", names=names)
    (tmp_path / "map.json").write_text(json.dumps(mapping))
    with pytest.raises(CharacterError, match="no recognisable humanoid"):
        load_character(tmp_path / "c.glb")
    character = load_character(tmp_path / "c.glb", str(tmp_path / "map.json"))
    err = direction_errors(retarget(take, character.skeleton, source), to_smplx, smplx_joints)
    assert err.mean() < 2.0


def test_bvh_hierarchy_is_a_character(tmp_path, take, source, smplx_joints, real_motion):
    """The project's own SMPL-X BVH export (Mixamo names, cm) read back as a character."""
    from gesturelsm.export import export_bvh

    export_bvh(real_motion.slice(0, 2), tmp_path / "s.bvh")
    character = load_character(tmp_path / "s.bvh")
    assert character.skeleton.kind == "bvh" and len(character.skeleton.bones) == 55 - 3 + 3
    result = retarget(take, character.skeleton, source)
    assert result.scale == pytest.approx(100.0, rel=1e-3)
    err = direction_errors(result, np.eye(3), smplx_joints)
    assert err.mean() < 2.0 and np.percentile(err, 95) < 5.0


def _glb(tmp_path, gltf: dict, name: str = "x.glb"):
    js = json.dumps(gltf).encode()
    js += b" " * (-len(js) % 4)
    p = tmp_path / name
    p.write_bytes(struct.pack("<4sII", b"glTF", 2, 20 + len(js)) + struct.pack("<I4s", len(js), b"JSON") + js)
    return p


def test_bad_files_get_one_clear_line(tmp_path, source):
    skel, _ = build_rig(source.rest_joints, fingers=False)
    cases = []
    (tmp_path / "notes.glb").write_text("hello, not a model")
    cases.append((tmp_path / "notes.glb", "not a glTF / VRM file"))
    (tmp_path / "trunc.glb").write_bytes(b"glTF\x02\x00\x00\x00")
    cases.append((tmp_path / "trunc.glb", "truncated"))
    cases.append((tmp_path / "avatar.fbx", "not a character file"))
    g = write_gltf(skel, tmp_path / "ok.glb")
    cases.append((_glb(tmp_path, {k: v for k, v in g.items() if k != "skins"}, "noskin.glb"), "no skin"))
    names = [n if n != "LeftForeArm" else "elbow_thing" for n in skel.names]
    write_gltf(skel, tmp_path / "nolimb.glb", names=names)
    cases.append((tmp_path / "nolimb.glb", "left_elbow.*missing"))
    cyc = json.loads(json.dumps(g))
    cyc["nodes"][3].setdefault("children", []).append(0)
    cases.append((_glb(tmp_path, cyc, "cycle.glb"), "cycle"))
    tiny, _ = build_rig(source.rest_joints, units=1e-5, fingers=False)
    write_gltf(tiny, tmp_path / "tiny.glb")
    cases.append((tmp_path / "tiny.glb", "absurd scale"))
    (tmp_path / "junk.bvh").write_text("MOTION\nFrames: 1\n")
    cases.append((tmp_path / "junk.bvh", "not a BVH"))
    for path, message in cases:
        with pytest.raises(InputError, match=message) as info:
            retarget_or_load(path, source)
        assert "\n" not in str(info.value)
    with pytest.raises(CharacterError, match="over the 0 MB limit"):
        load_character(tmp_path / "ok.glb", limit=100)
    (tmp_path / "map.json").write_text('{"pelvis": 3}')
    with pytest.raises(CharacterError, match="expected a JSON object"):
        load_character(tmp_path / "ok.glb", str(tmp_path / "map.json"))


def retarget_or_load(path, source):
    character = load_character(path)
    from gesturelsm.motion import MotionSequence

    retarget(MotionSequence(np.zeros((2, 165)), np.zeros((2, 3)), np.zeros((2, 100))), character.skeleton, source)


def test_cli_reports_a_bad_character_in_one_line(tmp_path, capsys, real_motion):
    real_motion.slice(0, 3).save(tmp_path / "m.npz")
    (tmp_path / "c.vrm").write_text("not a vrm")
    assert main(["export", str(tmp_path / "m.npz"), "--rig", str(tmp_path / "c.vrm"), "--glb",
                 str(tmp_path / "o.glb")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "c.vrm: not a glTF / VRM file" in err


def test_gltf_json_with_embedded_buffer_exports_as_glb(tmp_path, take, source):
    """A .gltf text file: its data: URI buffer goes into the GLB's binary chunk; one with a separate .bin file
    is read for its skeleton but refused for --glb with a message."""
    import base64

    from gesturelsm.export.glb import accessor_array, read_glb
    from gesturelsm.export.rig import export_rig_glb

    skel, _ = build_rig(source.rest_joints, fingers=False)
    g = write_gltf(skel, tmp_path / "c.glb")
    payload = np.arange(6, dtype=np.float32).tobytes()
    g["buffers"] = [{"byteLength": len(payload), "uri": "data:application/octet-stream;base64,"
                     + base64.b64encode(payload).decode()}]
    g["bufferViews"] = [{"buffer": 0, "byteOffset": 0, "byteLength": len(payload)}]
    g["accessors"] = [{"bufferView": 0, "componentType": 5126, "count": 2, "type": "VEC3"}]
    (tmp_path / "c.gltf").write_text(json.dumps(g))
    character = load_character(tmp_path / "c.gltf")
    export_rig_glb(take, character, tmp_path / "out.glb")
    gltf, blob = read_glb(tmp_path / "out.glb")
    assert "uri" not in gltf["buffers"][0] and gltf["buffers"][0]["byteLength"] == len(blob)
    np.testing.assert_array_equal(accessor_array(gltf, blob, 0).reshape(-1), np.arange(6))   # its data kept
    assert gltf["animations"][0]["channels"]
    g["buffers"] = [{"byteLength": len(payload), "uri": "c.bin"}]
    (tmp_path / "d.gltf").write_text(json.dumps(g))
    with pytest.raises(CharacterError, match="separate files"):
        export_rig_glb(take, load_character(tmp_path / "d.gltf"), tmp_path / "out2.glb")
