"""The page's character, server side (gesturelsm/webapp/character.py) and in the browser
(gesturelsm/webapp/player/src/character.js): the payload carries the retargeted rotations exactly; bad uploads give
one-line gr.Errors; three-vrm posed from the payload puts the right wrist where the retargeting does."""
from __future__ import annotations

import json
from pathlib import Path

import gradio as gr
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from _rigs import character_js_page
from _support import VRM, quiet
from gesturelsm.webapp.character import character_payload, decode, read_upload
from gesturelsm.retarget import retarget_motion



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
    assert "morphs" not in p and all("morph" not in m for m in p["methods"].values())   # no face presets, no face


def test_payload_moves_the_face_as_the_export_does(tmp_path):
    """A VRM 0.x binding visemes and blink: `morphs` lists every (mesh, target) they bind, and each method's `morph`
    is what the exported VRM (`export_rig_glb`) animates on those channels, frame by frame."""
    from _skinned import face_vrm
    from _support import synthetic_motion
    from gesturelsm.export.glb import accessor_array, read_glb
    from gesturelsm.export.rig import export_rig_glb
    from gesturelsm.retarget.face import driven_presets, morph_binds

    character = read_upload(str(face_vrm(tmp_path / "face.vrm", vrm="0")))
    gltf = character.document.gltf
    motions = {"a": synthetic_motion(frames=40, seed=1), "b": synthetic_motion(frames=40, seed=2)}
    p = character_payload(character, motions)
    channels = sorted({(m, k) for pr in driven_presets(gltf) for m, k, _ in morph_binds(gltf, pr)})
    assert len(channels) == 6 and [tuple(c) for c in p["morphs"]] == channels
    for method, seq in motions.items():
        out = export_rig_glb(seq, character, tmp_path / f"{method}.vrm")
        ex, blob = read_glb(out)
        anim = ex["animations"][0]
        per_mesh = {ex["nodes"][c["target"]["node"]]["mesh"]:
                    accessor_array(ex, blob, anim["samplers"][c["sampler"]]["output"]).reshape(40, -1)
                    for c in anim["channels"] if c["target"]["path"] == "weights"}
        assert sorted(per_mesh) == sorted({m for m, _ in channels})
        got = decode(p["methods"][method]["morph"], (40, len(channels)))
        np.testing.assert_allclose(got, np.stack([per_mesh[m][:, k] for m, k in channels], axis=1), atol=1e-6)
        assert got.max() > 0.1 and np.ptp(got, axis=0).max() > 0.1       # the mouth moves in this motion
    json.dumps(p)


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
def test_three_vrm_posed_from_the_payload_matches(character, payload, real_motion, tmp_path):
    import base64

    motions, p = payload
    frames = [0, 30, 59]
    with character_js_page(tmp_path) as page:
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
    r = retarget_motion(motions["ddim"], character)
    want = r.positions[frames, r.skeleton.bones["right_wrist"]]
    np.testing.assert_allclose(np.asarray(got), want, atol=1e-3)


def _request(wav, methods) -> tuple:
    # audio, text, textgrid, methods, steps, cfg, seed, ddim_steps, in_place, smoothing, size, auto_text, grounding,
    # language
    return (str(wav), "", None, methods, 1, 2.0, 0, 2, False, "light", 256, False, True, "auto")


def test_a_broken_character_is_a_warning_and_the_mannequin_stays(service, speech_wav, tmp_path):
    from gesturelsm.webapp.character import choose
    from gesturelsm.webapp.ui import _Handlers

    (tmp_path / "me.vrm").write_bytes(b"\x00" * 100)
    with pytest.warns(UserWarning, match="me.vrm: not a glTF / VRM file"):
        chosen, upload = choose(str(tmp_path / "me.vrm"))
    assert chosen is None and upload["value"] is None                 # the upload is emptied
    shown = _Handlers(service).show_motion(*_request(speech_wav, ["gesturelsm"]), chosen, progress=quiet)
    payload = list(shown)[-1][0]                                       # the button's last yield
    assert "character" not in payload and payload["bodies"][0]["method"] == "gesturelsm"


def test_a_chosen_character_gets_every_method_in_the_payload_and_the_downloads(service, speech_wav, tmp_path):
    from _rigs import build_rig, write_gltf
    from gesturelsm.body.model import resolve_body
    from gesturelsm.export.glb import read_glb
    from gesturelsm.webapp.character import choose
    from gesturelsm.webapp.ui import _Handlers

    skel, _ = build_rig(resolve_body(service.body).rest_joints(), fingers=False, axes=True)
    write_gltf(skel, tmp_path / "me.glb")
    chosen, upload = choose(str(tmp_path / "me.glb"))
    assert chosen.name == "me.glb" and "me.glb" in upload["label"]
    h, methods = _Handlers(service), list(service.methods)[:2]
    payload, _, _, out, *_ = list(h.show_motion(*_request(speech_wav, methods), chosen, progress=quiet))[-1]
    c = payload["character"]
    assert c["name"] == "me.glb" and list(c["methods"]) == [b["method"] for b in payload["bodies"]] == methods
    assert c["frames"] == payload["frames"] and c["nodes"][0] == skel.bones["pelvis"]
    served = Path(c["url"].split("file=", 1)[1])
    assert served.parent == out.job.folder and served.read_bytes() == (tmp_path / "me.glb").read_bytes()
    B, by_node = len(c["nodes"]), {n: i for i, n in enumerate(skel.nodes)}
    for method in methods:
        r = retarget_motion(out.motions[method], chosen, service.body)
        q = decode(c["methods"][method]["quats"], (r.num_frames, B, 4))
        got = Rotation.from_quat(q.reshape(-1, 4)).as_matrix().reshape(r.num_frames, B, 3, 3)
        np.testing.assert_allclose(got, r.local_rotation[:, [by_node[n] for n in c["nodes"]]], atol=1e-5)
    files = h.add_exports(out, chosen)[0]
    rigged = [Path(f) for f in files if Path(f).name.endswith("_me.glb")]
    assert sorted(p.name for p in rigged) == sorted(f"{m}_me.glb" for m in methods)
    gltf, _ = read_glb(rigged[0])
    assert [a["name"] for a in gltf["animations"]] == ["gesturelsm"]


def test_the_character_follows_the_pages_feet_on_the_ground_option(service, speech_wav, tmp_path):
    """A character with longer shins and wider hips than SMPL-X: with *Feet on the ground* (the default) the page's
    player and the character's download carry its feet planted on its own legs; with the option off, its legs as
    retargeted (and the SMPL-X motion ungrounded too)."""
    from _rigs import build_rig, write_gltf
    from _standing import other_legs
    from gesturelsm.body.model import resolve_body
    from gesturelsm.export.glb import accessor_array, read_glb
    from gesturelsm.webapp.character import choose
    from gesturelsm.webapp.ui import _Handlers

    skel, _ = build_rig(other_legs(resolve_body(service.body).rest_joints()), fingers=False)
    write_gltf(skel, tmp_path / "legs.glb")
    chosen, _ = choose(str(tmp_path / "legs.glb"))
    h, roots = _Handlers(service), {}
    for on in (True, False):
        request = _request(speech_wav, ["gesturelsm"])[:-2] + (on, "auto")
        payload, _, _, out, *_ = list(h.show_motion(*request, chosen, progress=quiet))[-1]
        assert out.job.grounding is on
        want = retarget_motion(out.motions["gesturelsm"], chosen, service.body, grounding=on)
        other = retarget_motion(out.motions["gesturelsm"], chosen, service.body, grounding=not on)
        c = payload["character"]
        root = decode(c["methods"]["gesturelsm"]["root"], (want.num_frames, 3))
        np.testing.assert_allclose(root, want.root_translation, atol=1e-5)
        if on:                                  # its own legs' grounding made a difference (off: the SMPL-X motion
            assert np.abs(root - other.root_translation).max() > 1e-3        # drifts, no foot of it stays put)
        rigged = next(Path(f) for f in h.add_exports(out, chosen)[0] if Path(f).name.endswith("_legs.glb"))
        gltf, blob = read_glb(rigged)
        anim = gltf["animations"][0]
        ch = next(c for c in anim["channels"] if c["target"]["path"] == "translation")
        np.testing.assert_allclose(accessor_array(gltf, blob, anim["samplers"][ch["sampler"]]["output"]),
                                   want.root_translation, atol=1e-5)
        roots[on] = root
    assert np.abs(roots[True] - roots[False]).max() > 1e-3


PAGE_NODES_JS = """() => { const p = window.gesturelsmPlayer, c = p.payload.character;
    return {frame: Number(p.element.dataset.frame), nodes: c.nodes, methods: p.bodies.map((b) => b.method),
            shown: p.bodies.map((b) => c.nodes.map((n) => b.character.nodes.get(n).quaternion.toArray())),
            quats: Object.fromEntries(Object.entries(c.methods).map(([m, v]) => [m, v.quats]))}; }"""


@pytest.mark.browser
def test_the_page_plays_every_method_on_an_uploaded_character(service, app_url, tmp_path):
    import soundfile as sf

    from _support import player_page, speech_like
    from gesturelsm.webapp.player.component import BUNDLE

    if not VRM.exists():
        pytest.skip(f"the shared character is not at {VRM} (../shared beside the repo)")
    if not BUNDLE.exists():
        pytest.skip(f"the player bundle {BUNDLE} is not built (cd gesturelsm/webapp/player && npm ci && npm run build)")
    sf.write(tmp_path / "speech.wav", speech_like(8.0, seed=2), 16000)
    player = "#motion-player"
    with player_page(app_url, player) as page:
        page.locator("#methods input[type=checkbox]").first.wait_for()
        page.locator("#character input[type=file]").set_input_files(str(VRM))
        page.locator("#character", has_text="43 humanoid bones").wait_for(timeout=60000)
        page.locator("#speech input[type=file]").first.set_input_files(str(tmp_path / "speech.wav"))
        page.locator("#speech [data-testid=download-link]").wait_for(state="attached", timeout=30000)
        page.locator("#generate").click()
        page.wait_for_selector(f"{player}[data-state=playing][data-character='cryptovoxels.vrm']", timeout=180000)
        page.wait_for_function("() => { const p = window.gesturelsmPlayer; "           # every method's body joined
                               "return Number(p.element.dataset.bodies) === p.payload.bodies.length; }", timeout=180000)
        # frames advance on the speech's clock, from its start (a loaded machine can join the last body after the 8 s
        # of speech have played)
        n0 = int(page.get_attribute(player, "data-frames"))
        page.evaluate("() => { const p = window.gesturelsmPlayer; p.seek(0); return p.play(); }")
        page.wait_for_function(f"() => Number(document.querySelector('{player}').dataset.frames) > {n0}",
                               timeout=30000)
        page.evaluate("() => window.gesturelsmPlayer.pause()")
        page.evaluate("() => window.gesturelsmPlayer.seek(1.5)")
        page.wait_for_function("""() => { const p = window.gesturelsmPlayer;
            return Number(p.element.dataset.frame) === Math.floor(p.clock.currentTime * p.fps + 1e-6); }""",
                               timeout=10000)
        got = page.evaluate(PAGE_NODES_JS)
    B = len(got["nodes"])
    assert got["frame"] == 45 and len(got["shown"]) == len(got["methods"]) >= 1
    for method, shown in zip(got["methods"], got["shown"]):       # each instance shows its own method's frame
        want = decode(got["quats"][method], (-1, B, 4))[got["frame"]]
        np.testing.assert_allclose(np.abs(np.sum(np.asarray(shown) * want, axis=1)), 1.0, atol=1e-5)


FACE_JS = """async ([b64, payload, live, chunk]) => {
    const bytes = Uint8Array.from(atob(b64), c => c.charCodeAt(0)).buffer;
    const base = await window.C.loadCharacter(bytes);
    const influences = (body) => { const out = [];
        body.meshes.forEach((objs, m) => objs.forEach((o) => out.push([m, Array.from(o.morphTargetInfluences)])));
        return out; };
    const page = new window.C.CharacterBody(base, payload, 'a', 0), shown = [];
    for (const f of chunk.frames) { page.pose(f); shown.push(influences(page)); }
    const streamed = new window.C.CharacterBody(base, live, 'live', 0), streamedShown = [];
    streamed.appendBones(new Float32Array(chunk.quats), new Float32Array(chunk.root), new Float32Array(chunk.morph));
    for (const f of chunk.frames) { streamed.pose(f); streamedShown.push(influences(streamed)); }
    let refused = null;
    try { streamed.appendBones(new Float32Array(chunk.quats), new Float32Array(chunk.root), null); }
    catch (e) { refused = e.message; }
    return {shown, streamedShown, refused};
}"""


@pytest.mark.browser
def test_the_characters_face_moves_in_the_browser(tmp_path):
    """A VRM with visemes and blink in three.js: the page's CharacterBody (payload) and the live one (a streamed
    chunk's morph weights) set each preset's morph target influence on the clone's mesh to the server's weight at the
    frame shown, the mouth open at some frame and different between frames."""
    import base64

    from _skinned import face_vrm
    from _support import synthetic_motion
    from gesturelsm.live.characters import CharacterStream

    path = face_vrm(tmp_path / "face.vrm", vrm="0")
    character = read_upload(str(path))
    seq = synthetic_motion(frames=40, seed=1)
    p = character_payload(character, {"a": seq})
    W = decode(p["methods"]["a"]["morph"], (40, len(p["morphs"])))
    stream = CharacterStream(character)
    q, r, w = stream.chunk(seq)
    np.testing.assert_allclose(w, W, atol=1e-6)
    frames = [int(W.sum(1).argmax()), int(W.sum(1).argmin())]          # the mouth widest open, and nearly shut
    chunk = {"frames": frames, "quats": q.ravel().tolist(), "root": r.ravel().tolist(), "morph": w.ravel().tolist()}
    with character_js_page(tmp_path) as page:
        got = page.evaluate(FACE_JS, [base64.b64encode(path.read_bytes()).decode(), p, stream.spec(), chunk])
    assert W[frames[0]].max() > 0.1 and np.abs(W[frames[0]] - W[frames[1]]).max() > 0.1
    for shown in (got["shown"], got["streamedShown"]):
        for f, meshes in zip(frames, shown):
            assert [m for m, _ in meshes] == [0]                           # the one glTF mesh, one three.js Mesh
            np.testing.assert_allclose([meshes[0][1][k] for _, k in p["morphs"]], W[f], atol=1e-6)
    assert "0 face weights for 40 frames of 6 morph channels" in got["refused"]
