"""The page's first body moves before its method is made (gesturelsm/serve/preview.py, the player's `partial`
bodies), in headless Chromium on the app served from this process over the tiny checkpoints: a slow generation (it
stops after its first decoded windows until the test lets it go on) still shows the first body moving, on fewer
frames than the speech has; once the method is made the player shows its finished, full-length motion. Skips, saying
why, without chromium or the player bundle."""
from __future__ import annotations

import threading

import pytest

from _support import player_page, served

pytestmark = pytest.mark.browser
PLAYER = "#motion-player"


class Gated:
    """A preview listener that, after handing on each preview, waits until `go` is set."""

    def __init__(self, inner, go: threading.Event, shown: threading.Event):
        self.inner, self.go, self.shown = inner, go, shown

    def wanted(self) -> bool:
        return self.inner.wanted()

    def show(self, parts) -> None:
        self.inner.show(parts)
        self.shown.set()
        self.go.wait(300)


@pytest.fixture
def slow_app(tiny_assets, tmp_path, monkeypatch):
    """The app over a service whose generations pause after their first decoded windows until the test says
    go; yields (url, go, shown)."""
    from gesturelsm.backends import ours
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.service import GestureService

    go, shown = threading.Event(), threading.Event()
    real = ours.window_decoder

    def slow(tokenizers, num_frames):
        decoder = real(tokenizers, num_frames)
        if decoder is not None:
            decoder.listener = Gated(decoder.listener, go, shown)
        return decoder
    monkeypatch.setattr(ours, "window_decoder", slow)
    service = GestureService.from_settings(ServiceSettings(checkpoints=str(tiny_assets), max_seconds=20,
                                                           workdir=str(tmp_path / "work")))
    try:
        with served(service) as url:
            yield url, go, shown
    finally:
        go.set()                                          # never leave a generation waiting


def test_the_first_body_moves_before_its_method_is_made_and_ends_full_length(slow_app, speech_wav):
    url, go, shown = slow_app
    with player_page(url, PLAYER) as page:
        page.locator("#speech input[type=file]").first.set_input_files(str(speech_wav))
        page.locator("#speech [data-testid=download-link]").wait_for(state="attached", timeout=60000)
        page.locator("#generate").click()
        page.wait_for_function(f"() => document.querySelector('{PLAYER}').dataset.state === 'playing'",
                               timeout=180000)
        early = page.evaluate("""() => { const p = window.gesturelsmPlayer;
            return {frames: p.frames(), total: p.payload.frames, bodies: Number(p.element.dataset.bodies),
                    partial: p.payload.bodies.filter((b) => b.partial).length}; }""")
        assert not go.is_set() and shown.is_set()                 # the method is not made: it waits on the test
        assert early["partial"] == 1 and early["bodies"] == 1 and 0 < early["frames"] < early["total"]
        go.set()
        page.wait_for_function("""() => { const p = window.gesturelsmPlayer;
            return p.payload.bodies.every((b) => b.motion && !b.partial)
              && Number(p.element.dataset.bodies) === p.payload.bodies.length && p.frames() === p.payload.frames; }""",
                               timeout=180000)
        end = page.evaluate("() => ({frames: window.gesturelsmPlayer.frames(), "
                            "total: window.gesturelsmPlayer.payload.frames})")
    assert end["frames"] == end["total"] == early["total"]
