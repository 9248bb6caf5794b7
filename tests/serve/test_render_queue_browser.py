"""Renders nobody else can block, in headless Chromium with two page sessions on one server (one video at
a time, the tiny checkpoints): session 1 generates 60 s of speech and its tab is closed while its video renders;
session 2 then generates 5 s: all its files (npz, BVH, GLB, keypoints, ARKit CSV) are offered before its video, its
video's progress shows frames, and its mp4 arrives; session 1's video was cancelled, never finished (had it run on,
session 2's video would have come only after it). Asserts on order and arrival, never on timing. Skips, saying why,
without chromium or the player bundle."""
from __future__ import annotations

import pytest
import soundfile as sf

from _support import CHROMIUM, generate_alone, open_page, served, speech_like

FILES = ("gesturelsm.npz", "gesturelsm.bvh", "gesturelsm.glb", "gesturelsm_keypoints.json", "gesturelsm_arkit.csv")

# records, in the page, the order in which the downloads (all of FILES) and the video's file appear
WATCH_JS = r"""(files) => { window.__order = [];
    const seen = (what) => { if (!window.__order.includes(what)) window.__order.push(what); };
    window.__watch = setInterval(() => {
        const names = [...document.querySelectorAll('#downloads .filename')]
            .map((td) => td.textContent.replace(/\s+/g, ''));                // stem and extension are two spans
        if (files.every((f) => names.includes(f))) seen('files');
        const v = document.querySelector('#video video');
        if (v && v.getAttribute('src')) seen('video');
    }, 50); }"""


@pytest.fixture(scope="module")
def queue_url(tiny_assets, tmp_path_factory):
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.service import GestureService
    from gesturelsm.webapp.player.component import BUNDLE

    if CHROMIUM is None:
        pytest.skip("chromium is not installed (apt-get install chromium libatomic1; scripts/setup.sh does it)")
    if not BUNDLE.exists():
        pytest.skip(f"the player bundle {BUNDLE} is not built (scripts/setup.sh builds it with npm)")
    # render_nice 0: on a loaded test machine a niced render may not reach its first frame for minutes (the order of
    # events is the same at any niceness)
    settings = ServiceSettings(checkpoints=str(tiny_assets), max_seconds=90, ahead=False, concurrency=1,
                               render_nice=0, workdir=str(tmp_path_factory.mktemp("queue_work")))
    service = GestureService.from_settings(settings)
    with served(service) as url:
        yield url, service


@pytest.mark.browser
@pytest.mark.slow
def test_a_closed_tab_video_does_not_block_the_next_visitor(queue_url, tmp_path):
    from playwright.sync_api import sync_playwright

    from app.screenshot import CHROMIUM_ARGS

    url, service = queue_url
    long_wav, short_wav = tmp_path / "long.wav", tmp_path / "short.wav"
    sf.write(long_wav, speech_like(60.0, seed=1), 16000)
    sf.write(short_wav, speech_like(5.0, seed=2), 16000)
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        try:
            one = open_page(browser, url)
            generate_alone(one, long_wav)
            # its video renders (the summary shows the real progress, not a fixed percentage)
            one.wait_for_function("() => /Rendering the video \\(mp4\\): frame \\d+\\/1800/.test("
                                  "document.querySelector('#summary').innerText)", timeout=600000)
            first = [d for d in service.workdir.glob("req-*") if not (d / "gestures.mp4").exists()]
            assert service.renders.running == 1
            one.close()                                                      # the tab closes mid-render

            two = open_page(browser, url)
            two.evaluate(WATCH_JS, list(FILES))
            generate_alone(two, short_wav)
            two.wait_for_function("() => window.__order.includes('video')", timeout=600000)   # its mp4 arrives
            order = two.evaluate("() => window.__order")
            assert order == ["files", "video"]                              # every file before the video
            assert "Video ready in" in two.locator("#summary").inner_text()
            assert two.evaluate("() => document.querySelector('#video video').getAttribute('src')").endswith(".mp4")
        finally:
            browser.close()
    assert first and all(not (d / "gestures.mp4").exists() for d in first)   # session 1's video: cancelled
    assert service.renders.running == 0 and service.renders.waiting == 0
