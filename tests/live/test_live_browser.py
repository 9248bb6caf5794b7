"""The Live tab in real headless Chromium, its microphone fed a real speech take (Chromium's fake capture device):
recording streams motion into the live player (`#live-player` data-frames advance, state `playing`), `#live-latency`
shows a positive median in milliseconds, and stopping ends the stream on the server (no live worker left).
Skips, saying why, without chromium, the player bundle, the shipped checkpoints or the real take in ../shared."""
from __future__ import annotations

import os
import re
import shutil
import threading
import time

import numpy as np
import pytest

from gesturelsm.pipeline import ASSETS

from app.screenshot import CHROMIUM_ARGS
from conftest import BEAT2, REAL_TAKE

CHROMIUM = next((p for p in ("/usr/lib/chromium/chromium", "/usr/bin/chromium", shutil.which("chromium") or "")
                 if p and os.path.exists(p)), None)
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
    if not (ASSETS / "generator" / "gesturelsm.safetensors").exists():
        pytest.skip(f"shipped generator checkpoints not found in {ASSETS / 'generator'}")
    from app.motion_player import BUNDLE
    if not BUNDLE.exists():
        pytest.skip(f"the player bundle {BUNDLE} is not built (scripts/setup.sh builds it with npm)")
    from app.ui import serve_locally
    from gesturelsm.app_service import GestureService, ServiceSettings

    service = GestureService.from_settings(ServiceSettings(workdir=str(tmp_path_factory.mktemp("live_work"))))
    demo, url = serve_locally(service)
    yield url
    demo.close()


def _value(page, elem_id: str) -> str:
    return page.evaluate(f"() => document.querySelector('#{elem_id} textarea, #{elem_id} input').value")


@pytest.mark.slow
def test_live_tab_streams_motion_from_the_microphone_and_stops(live_url, speech_48k):
    if CHROMIUM is None:
        pytest.skip("chromium is not installed (apt-get install chromium libatomic1; scripts/setup.sh does it)")
    from playwright.sync_api import sync_playwright

    args = CHROMIUM_ARGS + ["--use-fake-ui-for-media-stream", "--use-fake-device-for-media-stream",
                            f"--use-file-for-fake-audio-capture={speech_48k}"]
    assert live_workers() == 0
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=args)
        try:
            page = browser.new_page(viewport={"width": 1400, "height": 1300})
            page.goto(live_url)
            page.wait_for_selector(f"{PLAYER}[data-ready]", timeout=60000)
            assert page.get_attribute(PLAYER, "data-frames") == "0"
            page.locator("#live-mic .record-button").click()
            page.wait_for_function(f"() => Number(document.querySelector('{PLAYER}').dataset.frames) > 5",
                                   timeout=30000)
            assert page.get_attribute(PLAYER, "data-state") == "playing"
            assert live_workers() == 1                                   # this visitor's own stream
            n0 = int(page.get_attribute(PLAYER, "data-frames"))
            page.wait_for_timeout(2000)
            n1 = int(page.get_attribute(PLAYER, "data-frames"))
            assert n1 > n0                                               # the motion keeps coming
            latency = _value(page, "live-latency")
            assert re.fullmatch(r"\d+", latency) and int(latency) > 0, latency
            assert "p90" in _value(page, "live-stats") and "real-time factor" in _value(page, "live-stats")
            assert page.get_attribute(PLAYER, "data-gaps") is None        # every chunk arrived, in order
            page.locator("#live-mic .stop-button").click()
            page.wait_for_function("() => document.querySelector('#live-status textarea, #live-status input')"
                                   ".value === 'stopped'", timeout=30000)
            deadline = time.monotonic() + 10
            while live_workers() and time.monotonic() < deadline:
                time.sleep(0.1)
            assert live_workers() == 0                                   # the stream ended on the server
        finally:
            browser.close()
