"""The Sweep tab and the motion statistics in headless Chromium (tiny checkpoints, the real page and player): a
generated request's statistics appear beside the timing, a small sweep runs from the page, and one of its motions
opens in the in-browser player. Skips, saying why, without chromium or the player bundle (scripts/setup.sh)."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from _support import player_page, served

EXAMPLES = Path(__file__).resolve().parents[2] / "gesturelsm" / "webapp" / "examples"
PLAYER = "#motion-player"


@pytest.mark.browser
def test_a_small_sweep_runs_from_the_page_and_one_motion_opens_in_the_player(service):
    from playwright.sync_api import TimeoutError as PlaywrightTimeout

    from gesturelsm.webapp.player.component import BUNDLE

    if not BUNDLE.exists():
        pytest.skip(f"the player bundle {BUNDLE} is not built (scripts/setup.sh builds it with npm)")
    with served(service) as url, player_page(url, PLAYER) as page:
        page.locator("#speech input[type=file]").first.set_input_files(str(EXAMPLES / "hello.wav"))
        page.locator("#speech [data-testid=download-link]").wait_for(state="attached", timeout=60000)
        page.locator("#generate").click()
        page.wait_for_selector("#motion-stats[data-state=ready]", timeout=240000)
        # every method's row, then the speaker's: the table is refilled as each method's motion comes
        page.wait_for_function("() => { const rs = [...document.querySelectorAll('#motion-stats tr[data-method]')];"
                               " return rs.length > 0 && rs[rs.length - 1].dataset.method === 'speaker'; }",
                               timeout=240000)
        methods = page.eval_on_selector_all("#motion-stats tr[data-method]", "rs => rs.map(r => r.dataset.method)")
        assert methods[-1] == "speaker" and "gesturelsm" in methods
        tips = page.eval_on_selector_all("#motion-stats th[data-key]", "hs => hs.map(h => h.title)")
        from gesturelsm.evaluation.motion_stats import STATISTICS

        assert tips == [s.tooltip for s in STATISTICS] and all("Better:" in t for t in tips)

        page.get_by_role("tab", name="Sweep").click()
        page.locator("#sweep-speech input[type=file]").first.set_input_files(str(EXAMPLES / "hello.wav"))
        page.locator("#sweep-speech [data-testid=download-link]").wait_for(state="attached", timeout=60000)
        for other in ("Rectified flow", "DDIM"):
            page.locator("#sweep-methods label", has_text=other).click()
        page.locator("#sweep-steps textarea").fill("1 2")
        page.locator("#sweep-cfg textarea").fill("2")
        page.locator("#sweep-run").click()
        page.wait_for_selector("#sweep-table[data-state=ready]", timeout=240000)
        cells = page.eval_on_selector_all("#sweep-table tr[data-steps]",
                                          "rs => rs.map(r => [r.dataset.method, r.dataset.steps, r.dataset.cfg])")
        assert cells == [["gesturelsm", "1", "2"], ["gesturelsm", "2", "2"]]
        page.wait_for_selector("#sweep-plot img", timeout=30000)

        page.locator("#sweep-open").click()
        try:
            page.wait_for_function("() => ['playing', 'paused'].includes(document.querySelector('#motion-player')"
                                   ".dataset.state) && window.gesturelsmPlayer.payload?.bodies?.length === 1",
                                   timeout=90000)
        except PlaywrightTimeout:                       # say what the page shows instead
            seen = page.evaluate("""() => ({state: document.querySelector('#motion-player').dataset.state,
                error: document.querySelector('#motion-player').dataset.error,
                bodies: window.gesturelsmPlayer?.payload?.bodies?.length,
                toasts: [...document.querySelectorAll('.toast-body')].map(t => t.innerText)})""")
            pytest.fail(f"the sweep's motion did not open in the player: {seen}")
        payload = page.evaluate("() => window.gesturelsmPlayer.payload")
        assert payload["bodies"][0]["method"] == "gesturelsm" and "seed 0" in payload["bodies"][0]["label"]
        assert int(page.get_attribute(PLAYER, "data-frames")) > 0 and payload["frames"] > 0
        json.dumps(payload)
