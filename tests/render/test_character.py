"""Rendering the user's character's own mesh instead of the mannequin (`render_frames(..., character=)`,
`gesturelsm render --rig`): a box character the test builds has another silhouette than the mannequin, its
silhouette follows the motion (raised arms reach above the head), its texture colours it and is upright, the
generated mouth moves its morph targets, a skeleton without a mesh keeps the mannequin, and the shared
cryptovoxels.vrm draws whole and inside the frame."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

from _rigs import build_rig, vrm_body_bones
from _skinned import write_skinned_glb
from gesturelsm.cli import main
from gesturelsm.render import RenderStyle, RenderWarning, fit_camera, render_frames
from gesturelsm.retarget import Character, load_character
from _support import VRM

STYLE = RenderStyle(size=(128, 128), floor="none", shadow=False)


@pytest.fixture(scope="module")
def boxes(tmp_path_factory, body):
    skel, _ = build_rig(body.rest_joints(), fingers=False)
    path = tmp_path_factory.mktemp("boxes") / "boxes.vrm"
    write_skinned_glb(skel, path, vrm_body_bones(), color=(0.05, 0.1, 0.6, 1.0), half=0.05)
    return load_character(path)


def _mask(img: np.ndarray, style: RenderStyle = STYLE) -> np.ndarray:
    """Pixels that are not the (uniform: no floor, no shadow) background."""
    bg = np.round(np.asarray(style.background) * 255)
    return np.abs(img.astype(np.float64) - bg).max(-1) > 4


def test_the_character_has_its_own_silhouette(boxes, arms_down):
    cam = fit_camera([arms_down], style=STYLE)
    own = render_frames([arms_down], [0], style=STYLE, camera=cam, character=boxes)[0]
    mannequin = render_frames([arms_down], [0], style=STYLE, camera=cam)[0]
    a, b = _mask(own), _mask(mannequin)
    assert a.sum() > 300 and b.sum() > 300
    assert (a & b).sum() / (a | b).sum() < 0.8                                 # boxes are not the mannequin
    blue = own[a].mean(0)
    assert blue[2] > blue[0] + 40                                            # the material's colour, not clay


def test_the_silhouette_follows_the_motion(boxes, arms_down, arms_up):
    cam = fit_camera([arms_up], style=STYLE)
    down, up = (_mask(render_frames([m], [0], style=STYLE, camera=cam,
                                    character=boxes)[0]) for m in (arms_down, arms_up))
    top = lambda m: int(np.argmax(m.any(1)))                                 # noqa: E731  first row with the figure
    assert top(up) < top(down) - 5                                           # raised hands reach above the head
    rows = np.nonzero(down.any(1))[0]
    assert (up & ~down)[: top(down)].sum() > 20 and rows.size


def test_a_texture_colours_the_mesh(tmp_path, body, arms_down):
    skel, _ = build_rig(body.rest_joints(), fingers=False)
    tex = np.zeros((8, 8, 4), np.uint8)
    tex[..., 1], tex[..., 3] = 230, 255
    write_skinned_glb(skel, tmp_path / "green.vrm", vrm_body_bones(), color=(1, 1, 1, 1), texture=tex, half=0.05)
    img = render_frames([arms_down], [0], style=STYLE, character=load_character(tmp_path / "green.vrm"))[0]
    px = img[_mask(img)].astype(float)
    assert len(px) > 300 and px[:, 1].mean() > px[:, 0].mean() + 40 and px[:, 1].mean() > px[:, 2].mean() + 40


def test_a_skeleton_without_a_mesh_keeps_the_mannequin(boxes, arms_down):
    bare = Character(Path("skeleton.bvh"), boxes.skeleton)
    with pytest.warns(RenderWarning, match="without a mesh"):
        img = render_frames([arms_down], [0], style=STYLE, character=bare)[0]
    np.testing.assert_array_equal(img, render_frames([arms_down], [0], style=STYLE)[0])


def test_cli_render_rig(tmp_path, boxes, make_pose, capsys):
    seq = make_pose(4, np.linspace(-1.2, 1.2, 4))
    seq.save(tmp_path / "m.npz")
    args = ["render", str(tmp_path / "m.npz"), "--size", "64x64", "--quiet"]
    assert main(args + ["--out", str(tmp_path / "a.png"), "--frame", "3", "--rig", str(boxes.path)]) == 0
    assert main(args + ["--out", str(tmp_path / "b.png"), "--frame", "3"]) == 0
    own, mannequin = iio.imread(tmp_path / "a.png"), iio.imread(tmp_path / "b.png")
    assert own.shape == mannequin.shape == (64, 64, 3) and np.abs(own.astype(int) - mannequin).max() > 60
    assert main(args + ["--out", str(tmp_path / "v.mp4"), "--rig", str(boxes.path)]) == 0
    assert (tmp_path / "v.mp4").stat().st_size > 1000
    (tmp_path / "bad.vrm").write_text("not a character")
    capsys.readouterr()
    assert main(args + ["--out", str(tmp_path / "c.mp4"), "--rig", str(tmp_path / "bad.vrm")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("gesturelsm render: error: bad.vrm") and len(err.splitlines()) == 1
    assert not (tmp_path / "c.mp4").exists()


def test_cryptovoxels_draws_whole_and_inside_the_frame(real_motion):
    if not VRM.exists():
        pytest.skip(f"the shared character is not at {VRM} (../shared beside the repo)")
    style = replace(STYLE, size=(192, 192))
    frames = render_frames([real_motion.slice(0, 300)], [0, 150, 299], style=style, character=load_character(VRM))
    for img in frames:
        m = _mask(img, style)
        assert m.sum() > 1000                                                # a body, not a speck
        assert not (m[0].any() or m[-1].any() or m[:, 0].any() or m[:, -1].any())   # nothing cut off
        rows = np.nonzero(m.any(1))[0]
        assert rows[-1] - rows[0] > 0.6 * 192                                 # framed on the character's height


def test_the_generated_mouth_moves_the_characters_morph_targets(tmp_path, body, make_pose):
    """Jaw open vs closed on a character whose `aa` preset is a morph of its head box: the drawn vertices differ
    by exactly `aa`'s weight times the target's delta (turned into the renderer's axes), and nowhere else."""
    from gesturelsm.motion.skeleton import JOINT_INDEX
    from gesturelsm.render.figure import make_figure
    from gesturelsm.retarget.face import face_weights

    skel, _ = build_rig(body.rest_joints(), fingers=False)
    write_skinned_glb(skel, tmp_path / "mouth.vrm", vrm_body_bones(), presets=("aa",))
    character = load_character(tmp_path / "mouth.vrm")
    closed = make_pose(6, -1.2)
    opened = make_pose(6, -1.2)
    opened.poses[:, 3 * JOINT_INDEX["jaw"]] = np.linspace(0.0, 0.35, 6)
    figure = make_figure([closed, opened], body, character)
    a, b = (figure.pose(k, np.arange(6)).vertices.astype(np.float64) for k in (0, 1))
    aa = face_weights(body, opened.poses)["aa"]
    delta = figure.mesh.parts[0].targets[0] @ figure.align.T
    np.testing.assert_allclose(b - a, aa[:, None, None] * delta[None], atol=1e-5)
    assert aa[0] == 0 and aa[-1] == pytest.approx(1.0)


def test_a_texture_is_drawn_upright(tmp_path, body, arms_down):
    """glTF's v = 0 is the image's top row: a badge whose image is red above green shows red above green."""
    skel, _ = build_rig(body.rest_joints(), fingers=False)
    img = np.zeros((8, 8, 4), np.uint8)
    img[:4, :, 0], img[4:, :, 1], img[..., 3] = 255, 255, 255
    write_skinned_glb(skel, tmp_path / "badge.vrm", vrm_body_bones(), color=(0.02, 0.02, 0.02, 1), badge=img)
    style = replace(STYLE, size=(256, 256))
    frame = render_frames([arms_down], [0], style=style, character=load_character(tmp_path / "badge.vrm"))[0]
    f = frame.astype(int)
    red = (f[..., 0] > f[..., 1] + 80) & (f[..., 0] > f[..., 2] + 80)
    green = (f[..., 1] > f[..., 0] + 80) & (f[..., 1] > f[..., 2] + 80)
    assert red.sum() > 100 and green.sum() > 100
    assert np.nonzero(red)[0].max() < np.nonzero(green)[0].min() + 2                 # red rows above green rows


def test_primitives_sharing_vertices_draw_one_vertex_range(boxes, body, arms_down):
    """A second primitive over the same vertices (another material) is a second surface over the same range."""
    import copy

    from gesturelsm.render.figure import CharacterFigure

    doc = copy.deepcopy(boxes.document)
    prims = doc.gltf["meshes"][0]["primitives"]
    prims.append({**prims[0], "material": len(doc.gltf["materials"])})
    doc.gltf["materials"].append({"pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 1.0, 1.0]}})
    figure = CharacterFigure(Character(boxes.path, boxes.skeleton, doc), [arms_down], body)
    V = len(figure.mesh.parts[0].positions)
    assert figure.num_vertices == V and [(s.start, s.count) for s in figure.surfaces] == [(0, V), (0, V)]
    assert figure.faces.max() == V - 1
    assert figure.pose(0, np.arange(2)).vertices.shape == (2, V, 3)


def test_a_large_mesh_is_framed_and_drawn_in_chunks_with_the_same_result(boxes, monkeypatch):
    """The memory bounds for large meshes (frames.POSE_POINTS, frames.SAMPLE_BYTES, skinning.VERTEX_CHUNK) change
    how much is held at once, never the result: shrunk so that every step runs in chunks (held, then posed twice),
    the camera, the floor and the frames are the ones of the whole at once."""
    from _support import synthetic_motion
    from gesturelsm.render import frames
    from gesturelsm.render.figure import make_figure
    from gesturelsm.retarget import skinning

    seqs = [synthetic_motion(frames=9, seed=1), synthetic_motion(frames=9, seed=2)]
    style = RenderStyle(size=(128, 128))                                     # floor and contact shadows framed too

    def run():
        cam, floor = frames._layout(make_figure(seqs, None, boxes), style)
        return cam, floor, render_frames(seqs, [0, 4, 8], style=style, character=boxes)

    cam, floor, want = run()
    assert len(frames._sample_chunks(make_figure(seqs, None, boxes))[0]) == 1
    monkeypatch.setattr(skinning, "VERTEX_CHUNK", 7)
    monkeypatch.setattr(frames, "POSE_POINTS", 1)                           # one frame at a time, held
    assert isinstance(frames._sample_chunks(make_figure(seqs, None, boxes))[0], list)
    for shrink in (False, True):
        if shrink:
            monkeypatch.setattr(frames, "SAMPLE_BYTES", 1)                  # posed twice, nothing held
            assert len(frames._sample_chunks(make_figure(seqs, None, boxes))[0]) == 9
        cam2, floor2, got = run()
        assert floor2 == floor and np.array_equal(cam2.pose, cam.pose) and cam2.yfov == cam.yfov
        np.testing.assert_array_equal(got, want)


def test_a_character_with_very_many_vertices_is_framed_from_an_even_subset(boxes, monkeypatch):
    """Over FRAMING_VERTICES, the camera is fitted to every k-th vertex, posed exactly as drawing poses it."""
    from _support import synthetic_motion
    from gesturelsm.render import figure as fig

    seqs = [synthetic_motion(frames=5)]
    full = fig.make_figure(seqs, None, boxes)
    assert full.framing_vertices == full.num_vertices
    monkeypatch.setattr(fig, "FRAMING_VERTICES", 50)
    thin = fig.make_figure(seqs, None, boxes)
    step = -(-thin.num_vertices // 50)
    assert thin.framing_vertices == len(range(0, thin.num_vertices, step)) <= 50
    ids = np.arange(5)
    np.testing.assert_array_equal(thin.frame_points(0, ids), full.pose(0, ids).vertices[:, ::step])


def test_the_video_plants_the_characters_feet_on_its_own_legs(tmp_path, body):
    """A box character with longer shins, shorter thighs and wider hips under a motion whose SMPL-X feet are planted:
    what the video draws (the figure's skinned vertices) keeps its feet still while planted; `--grounding off` draws
    them as retargeted, sliding, and the frame differs."""
    from _standing import other_legs, segments, standing, swaying
    from gesturelsm.grounding import ground_motion
    from gesturelsm.render.figure import make_figure

    skel, _ = build_rig(other_legs(body.rest_joints()), fingers=False)
    write_skinned_glb(skel, tmp_path / "legs.vrm", vrm_body_bones(), half=0.04)
    character = load_character(tmp_path / "legs.vrm")
    g = ground_motion(swaying(swaying(standing(seconds=4.0, seed=1))))        # twice the sway: +-10 cm, 8 cm down
    assert g.note is None and g.contacts.all()
    ids = np.arange(15, g.motion.num_frames - 15)
    moved = {}
    for on in (True, False):
        V = make_figure([g.motion], body, character, grounding=on).pose(0, ids).vertices
        feet = V[0, :, 1] <= np.percentile(V[0, :, 1], 3)                   # the soles' vertices
        moved[on] = float(np.linalg.norm(V[:, feet] - V[:1, feet], axis=-1).max())
    assert moved[True] <= 0.001 < 0.005 < moved[False], moved              # held to the millimetre; off: slides
    g.motion.save(tmp_path / "m.npz")
    args = ["render", str(tmp_path / "m.npz"), "--size", "96x96", "--quiet", "--frame", "60", "--rig",
            str(tmp_path / "legs.vrm")]
    assert main(args + ["--out", str(tmp_path / "on.png")]) == 0
    assert main(args + ["--out", str(tmp_path / "off.png"), "--grounding", "off"]) == 0
    on, off = iio.imread(tmp_path / "on.png"), iio.imread(tmp_path / "off.png")
    assert np.abs(on.astype(int) - off).max() > 40
    assert segments(g.contacts[:, 0]) == [(0, g.motion.num_frames)]
