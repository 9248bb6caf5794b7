"""Bodies that join a running clock (gesturelsm/webapp/player/src/progressive.js, MotionPlayer.join / fail), in
headless Chromium on the player bundle alone (no app): the page's payload for one request arrives again as its
methods finish; the first body starts the speech, a later one joins at the current time (the speech does not restart
or jump, every body shows the frame of the same speech position), a failed method says why while the others play; a
method's motion that grows while it is made (body entries with `partial`, handed over as a slow generation would)
moves from its first windows on, each longer one and then the finished motion replacing its frames on the same clock.
Skips, saying why, without chromium or the player bundle (scripts/setup.sh builds it with npm)."""
from __future__ import annotations

import io

import numpy as np
import pytest

from _support import CHROMIUM, routed_page

pytestmark = pytest.mark.browser
T = 300                                     # 10 s at 30 fps


def _files(tmp_path) -> tuple[dict, list[np.ndarray]]:
    """The page's files (the player bundle, the mannequin, speech, two motions) and the two motions' rotations; the
    test skipped, saying why, without chromium or the player bundle."""
    import soundfile as sf

    from gesturelsm.body.model import resolve_body
    from gesturelsm.export.motion_codec import encode
    from gesturelsm.export.player_payload import body_glb, motion_record
    from gesturelsm.motion.sequence import MotionSequence
    from gesturelsm.webapp.player.component import BUNDLE

    if CHROMIUM is None:
        pytest.skip("chromium is not installed (apt-get install chromium libatomic1; scripts/setup.sh does it)")
    if not BUNDLE.exists():
        pytest.skip(f"the player bundle {BUNDLE} is not built (scripts/setup.sh builds it with npm)")
    body = resolve_body(None)
    rng = np.random.default_rng(5)
    files = {"/index.html": (b'<!doctype html><div id="p"></div>', "text/html"),
             "/player.js": (BUNDLE.read_bytes(), "text/javascript"),
             "/body.glb": (body_glb(body, None, tmp_path).read_bytes(), "model/gltf-binary")}
    wav = io.BytesIO()
    sf.write(wav, (0.2 * np.sin(np.arange(16000 * T // 30) * 0.05)).astype(np.float32), 16000, format="WAV")
    files["/speech.wav"] = (wav.getvalue(), "audio/wav")
    rotations = []
    for k in range(2):                      # two different smooth motions
        t = np.linspace(0, 6, T)[:, None]
        poses = 0.3 * np.sin(t * (1 + k) + rng.uniform(0, 6, (1, 165)))
        seq = MotionSequence(poses.astype(np.float32), np.zeros((T, 3), np.float32), np.zeros((T, 100), np.float32))
        rec = motion_record(seq, body)
        files[f"/m{k}.bin"] = (encode(rec), "application/octet-stream")
        rotations.append(rec.rotations)
    return files, rotations


def _payload(motions: list) -> dict:
    bodies = [{"label": f"{['Alpha', 'Beta'][k]} 8 steps CFG 2", "method": f"m{k}", "body": "/body.glb", "motion": mo,
               "expressions": 0} for k, mo in enumerate(motions)]
    bodies.append({"label": "Broken 8 steps CFG 2", "method": "broken", "body": "/body.glb", "motion": None,
                   "expressions": 0, **({"error": "it failed on the server"} if len(motions) > 1 and motions[1]
                                        else {})})
    return {"id": "req-1", "fps": 30, "frames": T, "duration": T / 30, "audio": "/speech.wav", "bodies": bodies}


STATE = """() => { const p = window.player, e = p.element;
    return {state: e.dataset.state, bodies: Number(e.dataset.bodies), failed: e.dataset.failed || null,
            t: p.clock ? p.clock.currentTime : null, frame: Number(e.dataset.frame),
            labels: [...e.querySelectorAll('.mp-label')].map((l) => l.textContent)}; }"""


def _start(page) -> None:
    """A player on the page's empty element (window.player)."""
    page.evaluate("""async () => { const m = await import('/player.js');
        window.player = new m.MotionPlayer(document.querySelector('#p')); }""")


def _paused(page) -> dict:
    """The player paused, once it shows the frame of its clock's time; its STATE then."""
    page.evaluate("() => window.player.pause()")
    page.wait_for_function("""() => { const p = window.player;
        return p.element.dataset.state === 'paused'
          && Number(p.element.dataset.frame) === Math.floor(p.clock.currentTime * p.fps + 1e-6); }""",
                           timeout=30000)
    return page.evaluate(STATE)


def test_a_body_that_arrives_later_joins_on_the_shared_clock(tmp_path):
    files, rotations = _files(tmp_path)

    with routed_page(files) as page:
        _start(page)
        page.evaluate("(p) => { window.player.load(p); }", _payload([None, None]))    # speech and slots only
        page.wait_for_function("() => window.player.element.querySelectorAll('.mp-label').length === 3",
                               timeout=30000)                                     # the three slots are built
        first = page.evaluate(STATE)
        assert (first["state"], first["bodies"]) == ("loading", 0)
        assert "generating" in first["labels"][0] and "generating" in first["labels"][2]
        page.evaluate("(p) => { window.player.load(p); }", _payload(["/m0.bin", None]))
        page.wait_for_function("() => window.player.element.dataset.state === 'playing'", timeout=30000)
        page.wait_for_function("() => window.player.clock.currentTime > 1.0", timeout=30000)
        before = page.evaluate(STATE)
        assert before["bodies"] == 1 and before["failed"] is None
        page.evaluate("(p) => { window.player.load(p); }", _payload(["/m0.bin", "/m1.bin"]))   # and one fails
        page.wait_for_function("() => window.player.element.dataset.bodies === '2'", timeout=30000)
        joined = page.evaluate(STATE)
        assert joined["t"] >= before["t"] and joined["state"] == "playing"        # nothing restarted
        assert joined["failed"] == "1" and joined["labels"][2].endswith("failed: it failed on the server")
        assert "generating" not in " ".join(joined["labels"])
        end = _paused(page)
        shown = [np.asarray(page.evaluate(f"() => window.player.jointRotations({k})")) for k in range(2)]
    f = end["frame"]
    assert f >= int(before["t"] * 30) and f > 30                # the same speech position, well past the start
    for k in range(2):                                          # both bodies show that frame of their own motion
        np.testing.assert_allclose(shown[k], rotations[k][f], atol=1e-6)
    assert np.abs(shown[0] - shown[1]).max() > 1e-3


def _growing(first: str | None, frames: int | None = None, second: str | None = None) -> dict:
    one = {"label": "Alpha 8 steps CFG 2", "method": "m0", "body": "/body.glb", "motion": first, "expressions": 0}
    if frames is not None:
        one.update(partial=True, frames=frames)
    two = {"label": "Beta 8 steps CFG 2", "method": "m1", "body": "/body.glb", "motion": second, "expressions": 0}
    return {"id": "req-1", "fps": 30, "frames": T, "duration": T / 30, "audio": "/speech.wav", "bodies": [one, two]}


def test_the_first_body_moves_on_its_first_windows_and_ends_on_the_finished_motion(tmp_path):
    import numpy as np

    from gesturelsm.export.motion_codec import MotionRecord, encode

    files, rotations = _files(tmp_path)
    raw = rotations[1]                                   # the partial motions: other frames than the finished m0
    for n in (60, 150):
        rec = MotionRecord(raw[:n].copy(), np.zeros((n, 3), np.float32), np.zeros((n, 0), np.float32), fps=30)
        files[f"/m0-upto-{n}.bin"] = (encode(rec), "application/octet-stream")
    frames = "window.player.frames()"

    with routed_page(files) as page:
        _start(page)
        page.evaluate("(p) => { window.player.load(p); }", _growing(None))
        page.wait_for_function("() => window.player.element.querySelectorAll('.mp-label').length === 2",
                               timeout=30000)
        page.evaluate("(p) => { window.player.load(p); }", _growing("/m0-upto-60.bin", 60))
        page.wait_for_function("() => window.player.element.dataset.state === 'playing'", timeout=30000)
        assert page.evaluate(f"() => {frames}") == 60 and page.evaluate(STATE)["bodies"] == 1   # before it is made
        page.evaluate("(p) => { window.player.load(p); }", _growing("/m0-upto-150.bin", 150))
        page.wait_for_function(f"() => {frames} === 150", timeout=30000)
        grown = page.evaluate(STATE)
        assert grown["state"] == "playing" and grown["bodies"] == 1
        page.evaluate("(p) => { window.player.load(p); }", _growing("/m0.bin", None, "/m1.bin"))
        page.wait_for_function(f"() => window.player.element.dataset.bodies === '2' && {frames} === {T}",
                               timeout=30000)
        page.wait_for_function("() => window.player.clock.currentTime > 2.5", timeout=30000)
        end = _paused(page)
        shown = np.asarray(page.evaluate("() => window.player.jointRotations(0)"))
        length = page.evaluate("() => Number(window.player.range.max)")
    assert end["t"] >= grown["t"] and length == pytest.approx(T / 30)                # one clock, the full length
    np.testing.assert_allclose(shown, rotations[0][end["frame"]], atol=1e-6)         # the finished motion's frame
