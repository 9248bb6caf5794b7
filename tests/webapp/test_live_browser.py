"""The Live tab in real headless Chromium, its microphone fed a real speech take (Chromium's fake capture device):
Record streams the microphone over the app's WebSocket (AudioWorklet PCM, gesturelsm/webapp/live_socket.py) and
motion into the live player (`#live-player` data-frames advance, state `playing`), `#live-latency` shows a positive
median in milliseconds, and Stop ends the stream on the server (no live worker left).
Skips, saying why, without chromium, the player bundle, the shipped checkpoints or the real take in ../shared."""
from __future__ import annotations

import re
import threading

import numpy as np
import pytest

from _support import player_page, served, shipped_service, until

from conftest import BEAT2, REAL_TAKE

PLAYER = "#live-player"


def live_workers() -> int:
    return sum(t.name == "gesturelsm-live" and t.is_alive() for t in threading.enumerate())


@pytest.fixture(scope="module")
def speech_48k(tmp_path_factory):
    """10 s of the real take (from 5 s in: speech), 48 kHz 16-bit, the format Chromium's fake device reads."""
    import scipy.signal
    import soundfile as sf

    wav = BEAT2 / "wave16k" / f"{REAL_TAKE}.wav"
    if not wav.exists():
        pytest.skip(f"real speech take not found at {wav} (../shared beside the repo, or GESTURELSM_SHARED)")
    y, sr = sf.read(wav, dtype="float32")
    assert sr == 16000
    y = scipy.signal.resample_poly(y[5 * sr:15 * sr], 3, 1)
    out = tmp_path_factory.mktemp("live_mic") / "speech48k.wav"
    sf.write(out, np.clip(y, -1, 1), 48000, subtype="PCM_16")
    return out


@pytest.fixture(scope="module")
def live_url(tmp_path_factory):
    with served(shipped_service(tmp_path_factory.mktemp("live_work"))) as url:
        yield url


HELLOS = """() => { window.__hellos = []; const send = WebSocket.prototype.send;
  WebSocket.prototype.send = function (data) {
    if (typeof data === 'string' && data.includes('sample_rate')) window.__hellos.push(JSON.parse(data));
    return send.call(this, data);
  }; }"""                                   # records each live stream's first message (the hello)


def _value(page, elem_id: str) -> str:
    return page.text_content(f"#{elem_id}")


@pytest.mark.slow
def test_live_tab_streams_motion_from_the_microphone_and_stops(live_url, speech_48k):
    args = ["--use-fake-ui-for-media-stream", "--use-fake-device-for-media-stream",
            f"--use-file-for-fake-audio-capture={speech_48k}"]
    assert live_workers() == 0
    with player_page(live_url, PLAYER, args) as page:
        assert page.get_attribute(PLAYER, "data-frames") == "0"
        page.evaluate(HELLOS)
        page.locator("#live-record").click()
        page.wait_for_function(f"() => Number(document.querySelector('{PLAYER}').dataset.frames) > 5",
                               timeout=30000)
        assert page.get_attribute(PLAYER, "data-state") == "playing"
        assert live_workers() == 1                                   # this visitor's own stream
        n0 = int(page.get_attribute(PLAYER, "data-frames"))
        page.wait_for_function(f"() => Number(document.querySelector('{PLAYER}').dataset.frames) > {n0}",
                               timeout=60000)                        # the motion keeps coming
        latency = _value(page, "live-latency")
        assert re.fullmatch(r"\d+", latency) and int(latency) > 0, latency
        assert "p90" in _value(page, "live-stats") and "real-time factor" in _value(page, "live-stats")
        assert page.get_attribute(PLAYER, "data-gaps") is None        # every chunk arrived, in order
        page.wait_for_function("() => { const l = window.gesturelsmPlayer.live.last; "
                               "return l && l.audio_seconds > 2; }", timeout=60000)   # over 2 s of speech streamed
        page.locator("#live-stop").click()
        page.wait_for_function("() => document.querySelector('#live-status').textContent === 'stopped'",
                               timeout=30000)
        live = "window.gesturelsmPlayer.live"                       # the page's one global API
        page.wait_for_function(f"() => {live}.ws === null", timeout=30000)  # the server closed it
        # every frame of the speech the server received reached the page: 30 per second of audio
        received, last = page.evaluate(f"() => [{live}.player.frames(), {live}.last]")
        assert last["audio_seconds"] > 2 and received == last["frames"]
        assert abs(received - last["audio_seconds"] * 30) <= 1
        until(lambda: live_workers() == 0, "the stream ended on the server")
        # the Feet on the ground option goes with the hello; it is on by default and locked while streaming
        assert page.evaluate("() => window.__hellos")[0]["grounding"] is True
        page.locator("#live-grounding").uncheck()
        page.locator("#live-record").click()
        page.wait_for_function("() => (window.__hellos || []).length === 2", timeout=30000)
        assert page.evaluate("() => window.__hellos")[1]["grounding"] is False
        assert page.locator("#live-grounding").is_disabled()
        page.locator("#live-stop").click()
        page.wait_for_function(f"() => {live}.ws === null", timeout=30000)
        assert page.locator("#live-grounding").is_enabled()
