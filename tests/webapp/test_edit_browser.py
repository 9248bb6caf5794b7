"""The page's Edit section in headless Chromium on the shipped checkpoints: generate 10 s, select 2-4 s, regions
upper + hands, Regenerate; the player shows the edited motion in place of the original (kept frames bit for bit),
A/B swaps it with the original on the same clock, the statistics follow it (the downloads: tests/webapp/
test_edit_section.py), a second edit chains, and Undo twice restores the original motion file's bytes. Skips, saying
why, without chromium, the player bundle or
the shipped checkpoints."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from _support import player_page, served, shipped_service, speech_like

PLAYER = "#motion-player"
# the statistics row of GestureLSM on the page, as its cells' unrounded values
STATS_JS = ("() => [...document.querySelectorAll('#motion-stats tr[data-method=gesturelsm] td[data-value]')]"
            ".map((td) => td.dataset.value)")
UPPER = [3, 6, 9, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21]


@pytest.fixture(scope="module")
def edit_url(tmp_path_factory):
    with served(shipped_service(tmp_path_factory.mktemp("edit_work"))) as url:
        yield url


def _record(url: str):
    from gesturelsm.export.player_payload import read_motion

    return read_motion(url.split("file=", 1)[1])


def _bytes(url: str) -> bytes:
    return Path(url.split("file=", 1)[1]).read_bytes()


def _payload(page) -> dict:
    return page.evaluate("() => window.gesturelsmPlayer.payload")


def _set_number(page, elem_id: str, value: float) -> None:
    box = page.locator(f"#{elem_id} input")
    box.fill(str(value))
    box.press("Enter")
    box.blur()


def _edit(page, start: float, end: float, regions: list[str], old_id: str) -> dict:
    _set_number(page, "edit-start", start)
    _set_number(page, "edit-end", end)
    for region in ("upper", "hands", "lower", "face"):
        box = page.locator("#edit-regions label", has_text=region).locator("input")
        if box.is_checked() != (region in regions):
            box.click()
    page.wait_for_selector(f"{PLAYER}[data-edit-start='{start:g}'][data-edit-end='{end:g}']", timeout=10000)
    page.locator("#edit-run").click()
    page.wait_for_function(f"""() => {{ const p = window.gesturelsmPlayer;
        return p.payload && p.payload.id !== '{old_id}' && p.element.dataset.ab === 'edited'; }}""", timeout=60000)
    return _payload(page)


def _shown_at(page, t: float) -> np.ndarray:
    page.evaluate(f"() => window.gesturelsmPlayer.seek({t})")
    page.wait_for_function("""() => { const p = window.gesturelsmPlayer;
        return Number(p.element.dataset.frame) === Math.floor(p.clock.currentTime * p.fps + 1e-6); }""", timeout=10000)
    frame = int(page.get_attribute(PLAYER, "data-frame"))
    return frame, np.asarray(page.evaluate("() => window.gesturelsmPlayer.jointRotations(0)"))


@pytest.mark.browser
def test_edit_compare_chain_and_undo_on_the_page(edit_url, tmp_path):
    wav = tmp_path / "speech.wav"
    sf.write(wav, speech_like(10.0), 16000)
    with player_page(edit_url, PLAYER) as page:
        page.locator("#methods label", has_text="DDIM").click()
        page.locator("#methods label", has_text="Rectified flow").click()             # GestureLSM alone
        page.locator("#auto-transcribe input[type=checkbox]").uncheck()
        page.locator("#speech input[type=file]").first.set_input_files(str(wav))
        page.locator("#speech [data-testid=download-link]").wait_for(state="attached", timeout=30000)
        page.locator("#generate").click()
        page.wait_for_selector(f"{PLAYER}[data-state=playing]", timeout=120000)
        page.locator("#edit-run").wait_for(state="visible", timeout=30000)
        first = _payload(page)
        page.wait_for_selector("#motion-stats[data-state=ready]", timeout=60000)
        stats_before = page.evaluate(STATS_JS)
        original_url = first["bodies"][0]["motion"]
        original = _bytes(original_url)
        page.evaluate("() => window.gesturelsmPlayer.pause()")

        one = _edit(page, 2, 4, ["upper", "hands"], first["id"])
        assert one["compare"]["method"] == "gesturelsm" and one["bodies"][0]["label"].endswith(", edited")
        before, after = _record(one["compare"]["motion"]), _record(one["bodies"][0]["motion"])
        assert np.array_equal(before.rotations, _record(original_url).rotations)
        assert not np.array_equal(after.rotations[60:120, UPPER], before.rotations[60:120, UPPER])
        lower = [0, 1, 2, 4, 5, 7, 8, 10, 11]
        assert np.array_equal(after.rotations[:, lower], before.rotations[:, lower])    # kept: bit for bit
        assert np.array_equal(after.rotations[:45], before.rotations[:45])               # before the range
        frame, shown = _shown_at(page, 3.0)
        np.testing.assert_allclose(shown, after.rotations[frame], atol=1e-6)          # the edit is on screen
        page.locator("#edit-ab").click()                                                 # A/B: the original
        page.wait_for_selector(f"{PLAYER}[data-ab=original]", timeout=10000)
        frame2, shown = _shown_at(page, 3.0)
        assert frame2 == frame
        np.testing.assert_allclose(shown, before.rotations[frame], atol=1e-6)
        page.locator("#edit-ab").click()
        page.wait_for_selector(f"{PLAYER}[data-ab=edited]", timeout=10000)

        old = json.dumps(stats_before, separators=(",", ":"))
        page.wait_for_function(f"() => {{ const s = document.querySelector('#motion-stats'); return s && "
                               f"s.dataset.state === 'ready' && JSON.stringify(({STATS_JS})()) !== '{old}'; }}",
                               timeout=60000)                                       # the statistics follow the edit

        two = _edit(page, 6, 8, ["lower"], one["id"])                                    # chained
        assert np.array_equal(_record(two["compare"]["motion"]).rotations, after.rotations)
        page.locator("#edit-undo").click()
        page.wait_for_function(f"() => window.gesturelsmPlayer.payload.id === '{one['id']}'", timeout=30000)
        page.locator("#edit-undo").click()
        page.wait_for_function(f"() => window.gesturelsmPlayer.payload.id === '{first['id']}'", timeout=30000)
        back = _payload(page)
        assert "compare" not in back and page.get_attribute(PLAYER, "data-ab") is None
        assert _bytes(back["bodies"][0]["motion"]) == original                           # the original bytes
        assert page.locator("#edit-undo").is_disabled()
