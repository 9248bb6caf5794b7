"""The in-browser motion player (gesturelsm/webapp/player), driven in headless Chromium on the shipped checkpoints:
it plays before the mp4 exists, shows exactly the generated frames of each method, follows the speech's clock,
and scrubbing keeps speech and motion within one frame. Skips, saying why, without chromium, the player bundle
(scripts/setup.sh builds it with npm) or the shipped checkpoints."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from _support import player_page, served, shipped_service, until

EXAMPLES = Path(__file__).resolve().parents[2] / "gesturelsm" / "webapp" / "examples"
PLAYER = "#motion-player"


def test_motion_file_round_trip_matches_the_glb_animation(tmp_path):
    """The player's motion file carries the same joint rotations and root as the animated GLB export."""
    from gesturelsm.export.glb import accessor_array, export_glb, read_glb
    from gesturelsm.export.player_payload import read_motion, write_motion
    from gesturelsm.motion.sequence import MotionSequence
    from gesturelsm.render.frames import resolve_body

    rng = np.random.default_rng(0)
    T = 12
    seq = MotionSequence(poses=rng.normal(0, 0.8, (T, 165)), trans=rng.normal(0, 0.2, (T, 3)),
                         expressions=rng.normal(0, 1, (T, 100)))
    body = resolve_body(None)
    path, E = write_motion(seq, body, tmp_path / "m.bin")
    rec = read_motion(path)
    assert (rec.kind, rec.frames, rec.start, rec.fps, rec.expressions.shape[1]) == ("quaternion", T, 0, 30, E)
    got = {"rotations": rec.rotations, "root": rec.root, "expressions": rec.expressions}
    gltf, blob = read_glb(export_glb(seq, tmp_path / "m.glb", body=body))
    chans = gltf["animations"][0]["channels"]
    samplers = gltf["animations"][0]["samplers"]
    for ch in chans:
        out = accessor_array(gltf, blob, samplers[ch["sampler"]]["output"])
        node, what = ch["target"]["node"], ch["target"]["path"]
        if what == "rotation":
            np.testing.assert_allclose(got["rotations"][:, node], out, atol=1e-5)
        elif what == "translation":
            np.testing.assert_allclose(got["root"], out, atol=1e-5)
        else:
            np.testing.assert_allclose(got["expressions"].reshape(-1), out.reshape(-1), atol=1e-5)


@pytest.fixture(scope="module")
def shipped(tmp_path_factory):
    service = shipped_service(tmp_path_factory.mktemp("player_work"))
    with served(service) as url:
        yield service, url


@pytest.fixture(scope="module")
def shipped_url(shipped):
    return shipped[1]


# how many bodies had their motion in each payload handed to the player (one payload per method made)
WATCH_PAYLOADS = """() => { const p = window.gesturelsmPlayer, load = p.load.bind(p); window.seen = [];
    p.load = (q) => { window.seen.push(q.bodies.filter((b) => b.motion).length); return load(q); }; }"""


def _motion(url: str, frames: int, expressions: int) -> np.ndarray:
    """(frames, 55, 4) rotations of a motion file the page was given (the app serves files by path)."""
    from gesturelsm.export.player_payload import read_motion

    rec = read_motion(url.split("file=", 1)[1])
    assert rec.frames == frames and rec.expressions.shape[1] == expressions
    return rec.rotations


def _shown(page, i: int) -> np.ndarray:
    return np.asarray(page.evaluate(f"() => window.gesturelsmPlayer.jointRotations({i})"))


@pytest.mark.browser
def test_player_plays_generated_methods_in_sync_with_the_speech(shipped, monkeypatch):
    service, shipped_url = shipped
    monkeypatch.setattr(service.ahead, "busy", lambda: True)      # nothing made ahead: the click makes each method
    with player_page(shipped_url, PLAYER) as page:
        assert page.get_attribute(PLAYER, "data-state") == "empty"
        page.locator("#methods label", has_text="DDIM").click()               # GestureLSM + rectified flow
        page.locator("#speech input[type=file]").first.set_input_files(str(EXAMPLES / "hello.wav"))
        page.locator("#speech [data-testid=download-link]").wait_for(state="attached", timeout=30000)
        page.evaluate(WATCH_PAYLOADS)
        page.locator("#generate").click()
        page.wait_for_selector(f"{PLAYER}[data-state=playing]", timeout=120000)
        page.wait_for_selector(f"{PLAYER}[data-bodies='2']", timeout=120000)
        # the speech plays with both bodies and new frames are drawn: from its start (a loaded machine can make the
        # second method after the 5 s clip has ended), the clock moves on by 0.3 s and the frame count grows, watched
        # in the page
        page.evaluate("() => { const p = window.gesturelsmPlayer; p.seek(0); return p.play(); }")
        page.wait_for_function("""() => { const f = Number(document.querySelector('#motion-player').dataset.frames);
            const t = window.gesturelsmPlayer.clock.currentTime;
            window.clock0 = window.clock0 || [f, t];
            return f > window.clock0[0] && t - window.clock0[1] > 0.3; }""", timeout=30000)
        seen = page.evaluate("() => window.seen")
        assert seen[0] == 0 and 1 in seen and seen[-1] == 2, seen          # the speech, one body, then both
        assert page.evaluate("() => window.gesturelsmPlayer.measure") is False    # no timings unless asked
        payload = page.evaluate("() => window.gesturelsmPlayer.payload")
        T, fps = payload["frames"], payload["fps"]
        assert [b["method"] for b in payload["bodies"]] == ["gesturelsm", "rectified_flow"]
        motions = [_motion(b["motion"], T, b["expressions"]) for b in payload["bodies"]]

        page.evaluate("() => window.gesturelsmPlayer.pause()")
        page.wait_for_selector(f"{PLAYER}[data-state=paused]", timeout=10000)
        for t in (0.4, 2.05, 3.3, 1.0):                  # scrub: the frame on screen follows the speech
            page.evaluate(f"() => window.gesturelsmPlayer.seek({t})")
            page.wait_for_function("""() => { const p = window.gesturelsmPlayer;
                return Number(p.element.dataset.frame) === Math.floor(p.clock.currentTime * p.fps + 1e-6); }""",
                                   timeout=10000)
            audio_t = page.evaluate("() => window.gesturelsmPlayer.clock.currentTime")
            frame = int(page.get_attribute(PLAYER, "data-frame"))
            assert abs(audio_t - t) < 1 / fps and abs(frame - t * fps) < 1
            shown = [_shown(page, i) for i in range(2)]
            for i in range(2):                           # each body shows its own method's frame exactly
                np.testing.assert_allclose(shown[i], motions[i][frame], atol=1e-6)
            assert np.abs(shown[0] - shown[1]).max() > 1e-3      # and the methods differ


@pytest.mark.browser
def test_the_motion_made_ahead_plays_at_the_click_in_one_payload(shipped):
    """The settings on screen are made while the visitor reads them (serve/ahead.py): the click's first payload
    already has every body, and the summary says so."""
    service, url = shipped
    with player_page(url, PLAYER) as page:
        page.locator("#methods label", has_text="DDIM").click()               # GestureLSM + rectified flow
        page.locator("#speech input[type=file]").first.set_input_files(str(EXAMPLES / "hello.wav"))
        page.locator("#speech [data-testid=download-link]").wait_for(state="attached", timeout=30000)
        until(lambda: service.ahead._run is not None and service.ahead._run.done and len(service.ahead._run.made) == 2,
              "both methods were made ahead", limit=120)
        page.evaluate(WATCH_PAYLOADS)
        page.locator("#generate").click()
        page.wait_for_selector(f"{PLAYER}[data-bodies='2']", timeout=120000)
        assert page.evaluate("() => window.seen") == [2]
        page.locator("#summary", has_text="Made ahead").wait_for(timeout=30000)
        assert service.ahead._run.taken


DECODE_JS = """async () => {
    const m = await import('/player.js');
    const buf = await (await fetch('/m.bin')).arrayBuffer();
    const r = m.decodeMotion(buf, 'm.bin');
    const errors = [];
    for (const [name, bytes] of [['cut.bin', buf.slice(0, buf.byteLength - 6)], ['head.bin', buf.slice(0, 12)],
                                 ['wav.bin', new TextEncoder().encode('RIFF' + 'x'.repeat(40)).buffer]]) {
      try { m.decodeMotion(bytes, name); errors.push(null); } catch (e) { errors.push(e.message); }
    }
    const c = m.decodeMotion(await (await fetch('/c.bin')).arrayBuffer(), 'c.bin');
    const f = m.decodeMotion(await (await fetch('/f.bin')).arrayBuffer(), 'f.bin');
    let fcut = null;
    try { m.decodeMotion((await (await fetch('/f.bin')).arrayBuffer()).slice(0, -4), 'fcut.bin'); }
    catch (e) { fcut = e.message; }
    return {kind: r.kind, joints: r.joints, fps: r.fps, start: r.start, frames: r.frames, meta: r.meta,
            rotations: Array.from(r.rotations), root: Array.from(r.root), expressions: Array.from(r.expressions),
            errors, plain: r.character, version: c.version, bones: c.character.bones, cmorphs: c.character.morphs,
            fmorphs: f.character.morphs, fbones: f.character.bones, fcut,
            f: [f.character.rotations, f.character.root, f.character.morph].map((a) => Array.from(a)),
            c: [c.rotations, c.root, c.expressions, c.character.rotations, c.character.root].map((a) => Array.from(a))};
}"""


@pytest.mark.browser
def test_the_page_decodes_what_python_encodes(tmp_path):
    """A live-style record (a chunk from frame 42, meta) written by gesturelsm/export/motion_codec.py and decoded by
    the bundle's decodeMotion in Chromium: the same header fields, meta and every float of every frame, also of a
    version-2 record's character section (with and without the face's morph weights); cut or foreign bytes give the
    decoder's message naming the source."""
    from _support import CHROMIUM, routed_page
    from gesturelsm.webapp.player.component import BUNDLE
    from gesturelsm.export.motion_codec import MotionRecord, encode

    if CHROMIUM is None:
        pytest.skip("chromium is not installed (apt-get install chromium libatomic1; scripts/setup.sh does it)")
    if not BUNDLE.exists():
        pytest.skip(f"the player bundle {BUNDLE} is not built (scripts/setup.sh builds it with npm)")
    rng = np.random.default_rng(3)
    T, E = 9, 4
    rec = MotionRecord(rng.normal(size=(T, 55, 4)).astype(np.float32), rng.normal(size=(T, 3)).astype(np.float32),
                       rng.normal(size=(T, E)).astype(np.float32), start=42,
                       meta={"status": "streaming", "frames": 51, "audio_seconds": 1.75, "median_latency_ms": None})
    from dataclasses import replace

    crec = replace(rec, bone_rotations=rng.normal(size=(T, 7, 4)).astype(np.float32),
                   bone_root=rng.normal(size=(T, 3)).astype(np.float32))
    frec = replace(crec, morph=rng.uniform(size=(T, 6)).astype(np.float32))          # a face: 6 morph channels
    files = {"/index.html": (b"<!doctype html><title>decode</title>", "text/html"),
             "/player.js": (BUNDLE.read_bytes(), "text/javascript"),
             "/m.bin": (encode(rec), "application/octet-stream"),
             "/c.bin": (encode(crec), "application/octet-stream"),
             "/f.bin": (encode(frec), "application/octet-stream")}

    with routed_page(files) as page:
        got = page.evaluate(DECODE_JS)
    assert (got["kind"], got["joints"], got["fps"], got["start"], got["frames"]) == ("quaternion", 55, 30, 42, T)
    assert got["meta"] == rec.meta
    for k in ("rotations", "root", "expressions"):             # float32 -> JS number -> float32: bit for bit
        np.testing.assert_array_equal(np.asarray(got[k], np.float32).reshape(getattr(rec, k).shape), getattr(rec, k))
    assert got["plain"] is None and (got["version"], got["bones"]) == (2, 7)
    for a, want in zip(got["c"], (crec.rotations, crec.root, crec.expressions, crec.bone_rotations, crec.bone_root)):
        np.testing.assert_array_equal(np.asarray(a, np.float32).reshape(want.shape), want)
    assert got["cmorphs"] == 0 and (got["fbones"], got["fmorphs"]) == (7, 6)
    for a, want in zip(got["f"], (frec.bone_rotations, frec.bone_root, frec.morph)):
        np.testing.assert_array_equal(np.asarray(a, np.float32).reshape(want.shape), want)
    assert got["fcut"].startswith("fcut.bin: ") and "6 morph weights" in got["fcut"] and "cut or padded" in got["fcut"]
    cut, head, wav = got["errors"]
    assert cut.startswith("cut.bin: ") and "cut or padded" in cut
    assert head.startswith("head.bin: 12 bytes, shorter than the 28-byte header")
    assert wav.startswith("wav.bin: not a GestureLSM motion record")


@pytest.mark.browser
def test_the_page_plays_the_methods_made_when_one_fails(shipped, monkeypatch):
    """A method that fails on the server: the page plays the others, and says which failed and why (above its place
    and in the summary)."""
    service, url = shipped

    def broken(*a, **k):
        raise RuntimeError("a bug in this method")
    monkeypatch.setattr(service.pipeline.backends["rectified_flow"], "generate", broken)
    with player_page(url, PLAYER) as page:
        page.locator("#methods label", has_text="DDIM").click()               # GestureLSM + rectified flow
        page.locator("#speech input[type=file]").first.set_input_files(str(EXAMPLES / "hello.wav"))
        page.locator("#speech [data-testid=download-link]").wait_for(state="attached", timeout=30000)
        page.locator("#generate").click()
        page.wait_for_selector(f"{PLAYER}[data-state=playing][data-failed='1']", timeout=120000)
        assert page.get_attribute(PLAYER, "data-bodies") == "1"
        assert page.locator(f"{PLAYER} .mp-label-failed").inner_text().endswith("failed: it failed on the server")
        page.locator("#summary", has_text="Rectified flow: it failed on the server").wait_for(timeout=30000)
        t0 = page.evaluate("() => window.gesturelsmPlayer.clock.currentTime")
        page.wait_for_function(f"() => window.gesturelsmPlayer.clock.currentTime > {t0 + 0.3}",
                               timeout=60000)                                                # it plays on
