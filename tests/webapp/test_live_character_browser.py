"""The Live tab on the character chosen with the page's Character upload, in real headless Chromium with its fake
microphone: after choosing ../shared's cryptovoxels.vrm it stands in the live player at rest, Record streams onto it
(`#live-player[data-character]`, the frames advance) and its right hand moves with the streamed motion; clearing the
upload puts the next stream back on the mannequin; a VRM with visemes and blink moves its face's morph targets with
the stream. Tiny checkpoints (the app tests' service). Skips, saying why, without chromium, the player bundle or the
character."""
from __future__ import annotations


import numpy as np
import pytest

from _support import VRM, until


PLAYER = "#live-player"
LIVE = f"document.querySelector('{PLAYER}').__live"


@pytest.fixture(scope="module")
def speech_48k(tmp_path_factory):
    """8 s of speech-like sound at 48 kHz 16-bit, the format Chromium's fake capture device reads."""
    import scipy.signal
    import soundfile as sf

    from _support import speech_like

    y = scipy.signal.resample_poly(speech_like(8.0, seed=3), 3, 1)
    out = tmp_path_factory.mktemp("live_mic") / "speech48k.wav"
    sf.write(out, np.clip(y, -1, 1), 48000, subtype="PCM_16")
    return out


def _hand(page, node: int) -> list[float]:
    """World position (player metres) of glTF node `node` of the live character on screen."""
    return page.evaluate(f"""(n) => {{ const b = {LIVE}.player.bodies[0], o = b.character.nodes.get(n);
        o.updateWorldMatrix(true, false); const e = o.matrixWorld.elements; return [e[12], e[13], e[14]]; }}""", node)


@pytest.mark.browser
def test_the_live_tab_streams_onto_the_chosen_character(app_url, speech_48k):
    from _support import player_page
    from gesturelsm.retarget import load_character
    from gesturelsm.webapp.player.component import BUNDLE

    if not VRM.exists():
        pytest.skip(f"the shared character is not at {VRM} (../shared beside the repo)")
    if not BUNDLE.exists():
        pytest.skip(f"the player bundle {BUNDLE} is not built (cd gesturelsm/webapp/player && npm ci && npm run build)")
    skel = load_character(VRM).skeleton
    hand = skel.nodes[skel.bones["right_wrist"]]
    args = ["--use-fake-ui-for-media-stream", "--use-fake-device-for-media-stream",
            f"--use-file-for-fake-audio-capture={speech_48k}"]
    with player_page(app_url, PLAYER, args) as page:
        assert page.get_attribute(PLAYER, "data-character") is None          # the mannequin until a stream
        page.locator("#character input[type=file]").set_input_files(str(VRM))
        page.locator("#character", has_text="43 humanoid bones").wait_for(timeout=60000)
        page.wait_for_function(f"() => {LIVE}.chosen && {LIVE}.chosen.name === 'cryptovoxels.vrm'", timeout=30000)
        page.wait_for_selector(f"{PLAYER}[data-character='cryptovoxels.vrm']", timeout=30000)   # at rest, no stream
        assert page.evaluate(f"() => {LIVE}.player.bodies[0].streamed && {LIVE}.player.frames() === 0")
        page.locator("#live-record").click()
        page.wait_for_function(f"() => {LIVE}.ws && {LIVE}.player.frames() > 0", timeout=60000)
        page.wait_for_selector(f"{PLAYER}[data-character='cryptovoxels.vrm']", timeout=30000)
        page.wait_for_function(f"() => Number(document.querySelector('{PLAYER}').dataset.frames) > 5", timeout=60000)
        assert page.get_attribute(PLAYER, "data-state") == "playing"
        seen = []

        def moved() -> bool:                                                 # the hand, sampled as the stream plays
            seen.append(_hand(page, hand))
            page.wait_for_timeout(200)
            assert np.isfinite(seen[-1]).all(), seen[-1]
            return len(seen) >= 12 and np.ptp(np.asarray(seen), axis=0).max() > 0.005     # it moves (metres)
        until(moved, "the character's hand moved 5 mm", every=0)
        info = page.evaluate(f"""() => {{ const f = {LIVE}, b = f.player.bodies[0];
            return {{streamed: b.streamed === true, frames: b.frames, shown: f.player.frames(),
                    error: f.element.dataset.error || f.element.dataset.characterError || null}}; }}""")
        assert info["streamed"] and info["frames"] == info["shown"] > 5 and info["error"] is None
        page.locator("#live-stop").click()
        page.wait_for_function(f"() => {LIVE}.ws === null", timeout=30000)
        # cleared: the next stream is on the mannequin again
        page.locator("#character button[aria-label='Clear']").click()
        page.wait_for_function(f"() => {LIVE}.chosen === null", timeout=30000)
        page.locator("#live-record").click()
        page.wait_for_function(f"""() => {LIVE}.ws && {LIVE}.player.frames() > 5
            && document.querySelector('{PLAYER}').dataset.character === undefined""", timeout=60000)
        page.locator("#live-stop").click()
        page.wait_for_function(f"() => {LIVE}.ws === null", timeout=30000)


FACE_JS = f"""() => {{ const f = {LIVE}, b = f.player.bodies[0], F = b.morphs.length, shown = f.player.shown;
    const mesh = b.meshes.get(0)[0];
    return {{morphs: b.morphs, frame: shown, frames: b.frames,
            streamed: Array.from(b.w.subarray(0, b.frames * F)),
            influences: Array.from(mesh.morphTargetInfluences)}}; }}"""


@pytest.mark.browser
def test_the_live_tab_moves_the_characters_face(app_url, speech_48k, tmp_path, monkeypatch):
    """A VRM with visemes and blink on the Live tab: after Record the stream names its morph channels, the page
    receives exactly the weights the server computed for each chunk, and the character's mesh shows the weights of the
    frame on screen, which change over time. The tiny test checkpoints keep the jaw shut, so the server's face sees
    the generated motion with its jaw opening and shutting (5 frames each)."""
    import gesturelsm.live.characters as live_character
    from _skinned import face_vrm
    from _support import player_page
    from gesturelsm.motion.skeleton import JOINT_INDEX
    from gesturelsm.webapp.player.component import BUNDLE

    sent, real = [], live_character.face_morph

    def talking(character, channels, seq, body, blinker=None):
        poses = seq.poses.copy()
        poses[:, 3 * JOINT_INDEX["jaw"]] = 0.3 * (np.arange(len(poses)) % 10 < 5)
        sent.append(real(character, channels, type(seq)(poses, seq.trans, seq.expressions, seq.betas), body,
                         blinker))
        return sent[-1]

    monkeypatch.setattr(live_character, "face_morph", talking)

    if not BUNDLE.exists():
        pytest.skip(f"the player bundle {BUNDLE} is not built (cd gesturelsm/webapp/player && npm ci && npm run build)")
    path = face_vrm(tmp_path / "face.vrm", vrm="1")
    args = ["--use-fake-ui-for-media-stream", "--use-fake-device-for-media-stream",
            f"--use-file-for-fake-audio-capture={speech_48k}"]
    with player_page(app_url, PLAYER, args) as page:
        page.locator("#character input[type=file]").set_input_files(str(path))
        page.locator("#character", has_text="humanoid bones").wait_for(timeout=60000)
        page.wait_for_function(f"() => {LIVE}.chosen && {LIVE}.chosen.name === 'face.vrm'", timeout=30000)
        page.locator("#live-record").click()
        page.wait_for_selector(f"{PLAYER}[data-character='face.vrm']", timeout=30000)
        page.wait_for_function(f"() => {LIVE}.player.bodies[0].frames > 40", timeout=60000)
        seen = []

        def changed() -> bool:                                               # the face, sampled as the stream plays
            seen.append(page.evaluate(FACE_JS))
            page.wait_for_timeout(250)
            return len(seen) >= 8 and len({tuple(np.round(s["influences"], 6)) for s in seen}) > 1
        until(changed, "the face's morph weights changed", every=0)
        page.locator("#live-stop").click()
        page.wait_for_function(f"() => {LIVE}.ws === null", timeout=30000)
    assert seen[0]["morphs"] == [[0, k] for k in range(6)]                     # the stream's channels
    last = seen[-1]
    W = np.asarray(last["streamed"], np.float32).reshape(last["frames"], 6)
    np.testing.assert_array_equal(W, np.concatenate(sent)[:len(W)])             # the server's weights, frame by frame
    assert W.max() > 0.05 and np.ptp(W, axis=0).max() > 0.05                   # the mouth opens and shuts
    for s in seen:                                                               # the mesh shows the frame on screen
        np.testing.assert_allclose(s["influences"], W[s["frame"]], atol=1e-6)
    assert len({tuple(np.round(s["influences"], 6)) for s in seen}) > 1          # and it changes over time
