"""A tab closed in the middle of Generate, in headless Chromium (the tiny checkpoints): page one generates 20 s of
speech and its tab is closed while its motion is being made; page two's Generate, sent at the same time, finishes
(motion, downloads and video: the page's "Ready"). Page one's generation stops at its next window (Gradio's unload,
fired by the end of the closed tab's heartbeat, sets its stop flag: webapp/closing.py) and nothing of it stays
registered.

The only help given to the race: page one's first window report waits, on the server, until the unload has fired
(so that on a fast machine the generation cannot end before the tab closes); what follows is the page's own code.
Asserts on order and arrival, never on timing. Skips, saying why, without chromium or the player bundle."""
from __future__ import annotations

import logging
import threading
from pathlib import Path

import pytest
import soundfile as sf

from _support import CHROMIUM, generate_alone, open_page, speech_like

WAIT_S = 600                     # bounds a page or a server that never gets there (not a timing assertion)


class Unloads(logging.Handler):
    """Sets `fired` when the page says a closed page's running work stops (closing.py's log line)."""

    def __init__(self):
        super().__init__()
        self.fired, self.stopped = threading.Event(), threading.Event()

    def emit(self, record):
        message = record.getMessage()
        if message == "a page closed: its running work stops":
            self.fired.set()
        elif message == "a page closed during its request: the work stopped":
            self.stopped.set()


@pytest.fixture(scope="module")
def gated(tiny_assets, tmp_path_factory):
    """The app over a service whose request for `long.wav` holds its first window's report until `release`."""
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.service import GestureService
    from gesturelsm.webapp.player.component import BUNDLE
    from gesturelsm.webapp.ui import serve_locally

    if CHROMIUM is None:
        pytest.skip("chromium is not installed (apt-get install chromium libatomic1; scripts/setup.sh does it)")
    if not BUNDLE.exists():
        pytest.skip(f"the player bundle {BUNDLE} is not built (scripts/setup.sh builds it with npm)")

    class Gated(GestureService):
        reached, release = threading.Event(), threading.Event()
        seen: list[str] = []                       # long.wav's progress messages, as the generation sends them

        def stream(self, req, progress=None, audio=None):
            if Path(req.audio_path).name != "long.wav" or progress is None:
                yield from super().stream(req, progress, audio)
                return

            def held(f, m):
                self.seen.append(m)
                if "window" in m and not self.reached.is_set():
                    self.reached.set()
                    self.release.wait(WAIT_S)
                progress(f, m)
            yield from super().stream(req, held, audio)

    settings = ServiceSettings(checkpoints=str(tiny_assets), max_seconds=60, ahead=False, concurrency=2,
                               render_nice=0, workdir=str(tmp_path_factory.mktemp("closed_tab_work")))
    service = Gated.from_settings(settings)
    demo, url = serve_locally(service)
    try:
        yield url, service, demo
    finally:
        Gated.release.set()
        demo.close()


def _page_work(demo):
    """The page's stop flags (closing.PageWork): the object whose `session_ended` is the page's unload."""
    fns = demo.blocks.fns
    (unload,) = [f for f in (fns.values() if isinstance(fns, dict) else fns)
                 if any(t[1] == "unload" for t in f.targets)]
    return unload.fn.__self__


@pytest.mark.browser
@pytest.mark.slow
def test_a_tab_closed_mid_generate_stops_its_generation_and_another_tab_finishes(gated, tmp_path):
    from playwright.sync_api import sync_playwright

    from app.screenshot import CHROMIUM_ARGS
    from gesturelsm.webapp.words import READY

    url, service, demo = gated
    long_wav, short_wav = tmp_path / "long.wav", tmp_path / "short.wav"
    sf.write(long_wav, speech_like(20.0, seed=1), 16000)
    sf.write(short_wav, speech_like(3.0, seed=2), 16000)
    unloads = Unloads()
    log = logging.getLogger("gesturelsm.app")
    log.addHandler(unloads)
    level = log.level
    log.setLevel(logging.INFO)
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
            try:
                one, two = open_page(browser, url), open_page(browser, url)
                generate_alone(one, long_wav)
                assert service.reached.wait(WAIT_S), "page one's generation never reached its first window"
                generate_alone(two, short_wav)                                    # page two's, at the same time
                one.close()                                                  # the tab closes mid-Generate
                assert unloads.fired.wait(WAIT_S), "the closed tab's unload never stopped its work"
                service.release.set()
                assert unloads.stopped.wait(WAIT_S), "page one's generation did not stop"
                two.wait_for_function("(ready) => document.body.innerText.includes(ready)",
                                      arg=READY.replace("**", ""), timeout=WAIT_S * 1000)
                assert two.locator("#video video").get_attribute("src").endswith(".mp4")
            finally:
                browser.close()
    finally:
        log.removeHandler(unloads)
        log.setLevel(level)
    windows = [m for m in service.seen if "window" in m]
    total = int(windows[0].rsplit("/", 1)[1])
    assert total > 1 and windows == [f"gesturelsm: window 1/{total}"]         # no window sampled after the close
    assert not any("done" in m for m in service.seen)
    assert _page_work(demo).pages == 0                                       # nothing of either page registered
    assert service.ahead._requests == 0
