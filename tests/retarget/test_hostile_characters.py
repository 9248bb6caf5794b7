"""Hostile character files (tests/_hostile_characters.py, shared with benchmarks/hostile_characters.py): each is
refused with one line naming the file and the problem, before anything large is allocated, by every entry point
(`load_character` under `export --rig` / `render --rig`, the page's Character upload), or is usable with a note."""
from __future__ import annotations

import re
import tracemalloc
from pathlib import Path

import gradio as gr
import numpy as np
import pytest

from _hostile_characters import character_cases, write_characters
from _support import VRM, synthetic_motion
from gesturelsm.cli import main
from gesturelsm.render.figure import make_figure
from gesturelsm.retarget import CharacterError, load_character
from gesturelsm.retarget.mesh import character_mesh
from gesturelsm.webapp.character import choose, read_upload

CASES = character_cases(VRM, slow=False)


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    return write_characters(CASES, tmp_path_factory.mktemp("hostile"))


@pytest.fixture(scope="module")
def motion_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("motion") / "m.npz"
    synthetic_motion(frames=10).save(path)
    return path


def _cli(args: list[str], capsys) -> tuple[int, str]:
    code = main(args)
    return code, capsys.readouterr().err.strip()


def _peak_mb(fn) -> float:
    """Python's peak allocation (MB) while fn() runs (numpy arrays included)."""
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1] / 2 ** 20
    finally:
        tracemalloc.stop()


def test_a_truncated_glb_is_refused_by_export_render_and_the_upload(files, motion_file, tmp_path, capsys):
    names = ["truncated_half.vrm"] + (["truncated_cryptovoxels.vrm"] if VRM.exists() else [])
    for name in names:
        out = tmp_path / f"{name}.out.vrm"
        code, err = _cli(["export", str(motion_file), "--rig", str(files[name]), "--glb", str(out)], capsys)
        assert code == 2 and err.count("\n") == 0 and f"{name}: truncated GLB file: its header says" in err
        assert not out.exists()                                          # no corrupt file written
        code, err = _cli(["render", str(motion_file), "--rig", str(files[name]), "--frame", "0",
                          "--out", str(tmp_path / "f.png")], capsys)
        assert code == 2 and "truncated GLB file" in err and "Traceback" not in err
        with pytest.warns(UserWarning, match=f"{name}: truncated GLB file"):
            chosen, upload = choose(str(files[name]))
        assert chosen is None and upload["value"] is None                # the mannequin stays


def test_an_accessor_without_data_is_refused_before_its_zeros_are_allocated(files, motion_file, tmp_path, capsys):
    """100,000,000 vertices in a 20 KB file: refused from the JSON; 16,000,000 indices (64 MB, an accessor's
    limit): refused by the drawing limits before any is decoded."""
    def load_big():
        with pytest.raises(CharacterError, match="accessor 0 asks for 100,000,000 VEC3 elements"):
            load_character(files["vertices_1e8_no_data.vrm"])

    assert _peak_mb(load_big) < 20
    character = load_character(files["indices_16M_no_data.glb"])

    def draw():
        with pytest.raises(CharacterError, match="5,333,333 triangles; a character may have at most 2,000,000"):
            character_mesh(character.document, character.skeleton)

    assert _peak_mb(draw) < 20
    code, err = _cli(["render", str(motion_file), "--rig", str(files["vertices_1e8_no_data.vrm"]), "--frame", "0",
                      "--out", str(tmp_path / "f.png")], capsys)
    assert code == 2 and err.count("\n") == 0 and "100,000,000" in err


@pytest.mark.parametrize("name", ["texture_12k.vrm", "texture_20k.vrm", "texture_jpeg_60k.vrm"])
def test_a_texture_too_large_to_decode_becomes_a_note(name, files):
    """The size comes from the image's header; nothing is decoded (a 20k x 20k PNG is Pillow's decompression
    bomb, a 12k x 12k one would take about 600 MB), and the mesh is drawn in its material's colour."""
    character = load_character(files[name])
    meshes = []
    assert _peak_mb(lambda: meshes.append(character_mesh(character.document, character.skeleton))) < 40
    side = name.split("_")[-1].split(".")[0].replace("k", ",000")
    assert any(f"{side} x {side} texels" in n and "material's colour" in n for n in meshes[0].notes)
    assert all(p.texture is None for p in meshes[0].parts)


@pytest.mark.parametrize("name", ["json_depth_100k.vrm", "node_as_string.vrm", "matrix_3_elements.vrm",
                                  "quaternion_text.vrm", "skins_object.vrm"])
def test_malformed_character_json_is_one_line_in_the_cli_and_on_the_page(name, files, motion_file, tmp_path, capsys):
    case = next(c for c in CASES if c.name == name)
    code, err = _cli(["export", str(motion_file), "--rig", str(files[name]), "--glb", str(tmp_path / "o.vrm")],
                     capsys)
    assert code == 2 and err.count("\n") == 0 and "Traceback" not in err
    assert err.startswith(f"gesturelsm export: error: {name}: ")
    with pytest.warns(UserWarning, match=case.refused) as caught:
        chosen, _ = choose(str(files[name]))
    assert chosen is None and str(caught[0].message).startswith(f"{name}: ")


def test_a_nan_translation_is_refused_at_upload(files):
    """Refused once, at upload, rather than accepted and then failing every Generate."""
    for name in ("translation_nan.vrm", "translation_nan.gltf", "translation_inf.vrm"):
        with pytest.warns(UserWarning, match=f"{name}: damaged glTF: node 1's translation is not 3 finite numbers"):
            chosen, upload = choose(str(files[name]))
        assert chosen is None and upload["value"] is None


def test_a_character_whose_rest_pose_cannot_be_retargeted_is_refused_at_upload(tmp_path):
    """An absurd scale is found when retargeting; the upload retargets the rest pose once, so no Generate meets it."""
    from _rigs import build_rig, write_gltf
    from gesturelsm.body.model import resolve_body

    tiny, _ = build_rig(resolve_body(None).rest_joints(), units=1e-5, fingers=False)
    write_gltf(tiny, tmp_path / "tiny.glb")
    with pytest.warns(UserWarning, match="tiny.glb: absurd scale"):
        assert choose(str(tmp_path / "tiny.glb"))[0] is None


def test_an_unexpected_failure_reading_an_upload_still_says_so_in_one_line(monkeypatch, tmp_path):
    import gesturelsm.webapp.character as page

    def broken(path):
        raise RuntimeError("a bug")

    monkeypatch.setattr(page, "read_upload", broken)
    with pytest.warns(UserWarning, match="me.vrm: this file could not be read"):
        assert page.choose(str(tmp_path / "me.vrm"))[0] is None


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_each_crafted_character_gets_its_one_line_answer(case, files):
    path = files[case.name]
    if case.refused:
        with pytest.raises(CharacterError, match=case.refused) as info:
            load_character(path)
        assert "\n" not in str(info.value) and str(info.value).startswith(f"{case.name}: ")
        if case.page:
            with pytest.raises(gr.Error) as page:
                read_upload(str(path))
            assert page.value.message == str(info.value)
        return
    character = load_character(path)
    page_refusal = case.drawn or case.upload
    if case.page and page_refusal:
        with pytest.raises(gr.Error) as info:
            read_upload(str(path))
        message = info.value.message
        assert re.search(page_refusal, message) and "\n" not in message and message.startswith(f"{case.name}: ")
    elif case.page:
        assert read_upload(str(path)) is not None
    seqs = [synthetic_motion(frames=4)]                    # (too short to plant feet on: no grounding, no note)
    if case.drawn:
        with pytest.raises(CharacterError, match=case.drawn):
            make_figure(seqs, None, character, grounding=False)
        return
    notes = make_figure(seqs, None, character, grounding=False).notes
    if case.note:
        assert any(n.startswith(f"{case.name}: ") and re.search(case.note, n) for n in notes)
    else:
        assert notes == []


def test_the_control_is_a_usable_character(files):
    """The crafted files differ from a character that retargets and draws, so each refusal is the attack's."""
    character = read_upload(str(files["valid.vrm"]))
    mesh = character_mesh(character.document, character.skeleton)
    assert len(character.skeleton.bones) >= 15 and mesh.num_vertices > 100 and mesh.notes == []
    assert mesh.parts[0].texture is not None and np.ptp(mesh.parts[0].texture[..., 0]) > 0
