"""The page as a visitor meets it, in headless Chromium on the shipped checkpoints:
- each upload its own words: upload speech A, Generate (automatic transcript), upload speech B, Generate: the box is
  emptied on B's upload and B is transcribed itself (its summary says so, its recognised words are B's, never A's);
  words the visitor typed stay on a new upload with a visible note; the API's calls never share words either;
- the click is seen: at 1400x1000 Generate brings the player and its status line into view, and the status says
  what is made;
- the edit range is drawn on the player's timeline (`.mp-edit-range` visible, non-zero width) while it is set and
  after the edit;
- the layout: at 1280x800 and 1920x1080 no table in #timings, #motion-stats-box or #sweep-table-box is cut (each
  fits its column or scrolls inside it) and no heading breaks inside a word; the idle body stands on the floor with
  its arms down, whole in the window.
Skips, saying why, without chromium, the player bundle, the shipped checkpoints or speech recognition / eSpeak NG."""
from __future__ import annotations

import re

import pytest
import soundfile as sf

from _asr_support import SR, asr_available, speak
from _support import gradio_client, player_page, served, shipped_service
from gesturelsm.webapp.layout import TABLE_BOXES, TABLES_JS

PLAYER = "#motion-player"
A_WORDS = "yesterday my sister walked to the market and bought fresh bread apples and a bottle of milk"
B_WORDS = "the weather will be cold and windy tomorrow so please bring a warm coat and gloves"
BAND_JS = """() => { const b = document.querySelector('#motion-player .mp-edit-range');
    return b ? {display: getComputedStyle(b).display, width: b.getBoundingClientRect().width} : null; }"""
# the player's canvas and the status line under it are inside the window
IN_VIEW_JS = """() => { const c = document.querySelector('#motion-player canvas').getBoundingClientRect();
    const s = document.querySelector('#generate-status').getBoundingClientRect();
    return c.top >= -1 && c.bottom <= innerHeight + 1 && s.top >= 0 && s.bottom <= innerHeight + 1; }"""


@pytest.fixture(scope="module")
def page_url(tmp_path_factory):
    with served(shipped_service(tmp_path_factory.mktemp("page_work"))) as url:
        yield url


@pytest.fixture(scope="module")
def speeches(tmp_path_factory):
    """Two eSpeak NG speeches of different sentences (wav files)."""
    if not asr_available():
        pytest.skip("speech recognition (Whisper tiny.en) or eSpeak NG is not available")
    folder = tmp_path_factory.mktemp("speeches")
    paths = []
    for name, words in (("a.wav", A_WORDS), ("b.wav", B_WORDS)):
        sf.write(folder / name, speak(words, "en-us"), SR)
        paths.append(folder / name)
    return paths


def _words(text: str) -> set[str]:
    return set(re.findall(r"[a-z]+", text.lower()))


def _one_method(page) -> None:
    page.locator("#methods label", has_text="DDIM").click()
    page.locator("#methods label", has_text="Rectified flow").click()             # GestureLSM alone


def _upload(page, wav, box: str = "#speech") -> None:
    """Upload `wav` as a visitor does: speech already there is removed first (its x button), then the file chosen."""
    clear = page.locator(f"{box} button[aria-label='Clear']")
    if clear.count():
        clear.first.click()
    page.locator(f"{box} input[type=file]").first.set_input_files(str(wav))
    page.locator(f"{box} [data-testid=download-link]").wait_for(state="attached", timeout=30000)


def _generated(page, old_id: str | None = None) -> dict:
    """Click Generate and wait until the request's body plays and its downloads are offered; its payload."""
    page.locator("#generate").click()
    page.wait_for_function(f"""() => {{ const p = window.gesturelsmPlayer;
        return p.payload && p.payload.id !== '{old_id}' && p.element.dataset.state === 'playing'; }}""", timeout=180000)
    return page.evaluate("() => window.gesturelsmPlayer.payload")


def _transcript(page) -> str:
    return page.locator("#transcript textarea").input_value()


@pytest.mark.browser
def test_each_upload_is_timed_with_its_own_words(page_url, speeches):
    a, b = speeches
    with player_page(page_url, PLAYER) as page:
        _one_method(page)
        _upload(page, a)
        first = _generated(page)
        page.wait_for_function("() => document.querySelector('#transcript textarea').value.trim().length > 0",
                               timeout=60000)
        heard_a = _words(_transcript(page))
        assert len(heard_a & _words(A_WORDS)) >= 5, heard_a           # A's words, recognised, in the box

        _upload(page, b)                                               # another speech: A's words go
        page.wait_for_function("() => document.querySelector('#transcript textarea').value === ''", timeout=10000)
        assert not page.locator("#transcript-note").is_visible()
        _generated(page, first["id"])
        page.wait_for_function("() => document.querySelector('#transcript textarea').value.trim().length > 0",
                               timeout=60000)
        summary = page.locator("#summary").inner_text()
        assert "automatic transcript" in summary and "aligned" not in summary, summary
        heard_b = _words(_transcript(page))
        assert len(heard_b & _words(B_WORDS)) >= 5, heard_b            # B's own recognised words
        assert not (heard_b & _words(A_WORDS)) - _words(B_WORDS) - {"a", "and", "the", "to", "of"}, heard_b

        page.locator("#transcript textarea").fill("words the visitor typed")     # typed words stay, with a note
        page.locator("#transcript textarea").blur()
        _upload(page, a)
        page.locator("#transcript-note").wait_for(state="visible", timeout=10000)
        assert "typed" in page.locator("#transcript-note").inner_text()
        assert _transcript(page) == "words the visitor typed"


@pytest.mark.browser
def test_the_api_never_reuses_an_earlier_calls_words(page_url, speeches):
    """`/generate_motion` (the button's endpoint) called twice without a transcript: each call's recognised words are
    its own speech's."""
    from gradio_client import handle_file

    client = gradio_client(page_url)
    heard = []
    for wav in speeches:
        # audio, text, textgrid, methods, steps, cfg, seed, ddim_steps, in_place, smoothing, size, auto, ground, lang
        out = client.predict(handle_file(str(wav)), "", None, ["gesturelsm"], 2, 2.0, 0, 2, False, "light", 256,
                             True, True, "auto", api_name="/generate_motion")
        heard.append(_words(out[3]))                                   # the transcript box
    assert len(heard[0] & _words(A_WORDS)) >= 5 and len(heard[1] & _words(B_WORDS)) >= 5, heard


# each box that shows Gradio's progress while the page runs, with its animation, recorded when it appears
WATCH_BUSY = """() => { window.busySeen = [];
    const look = () => { for (const e of document.querySelectorAll('.wrap.generating')) {
        const k = [(e.closest('[id]') || {}).id, getComputedStyle(e).animationName];
        if (!window.busySeen.some((s) => s[0] === k[0] && s[1] === k[1])) window.busySeen.push(k); } };
    new MutationObserver(look).observe(document.body, {subtree: true, childList: true, attributes: true,
                                                       attributeFilter: ['class']}); }"""


@pytest.mark.browser
def test_generate_is_seen_and_the_edit_range_is_drawn(page_url, speeches):
    with player_page(page_url, PLAYER) as page:
        page.set_viewport_size({"width": 1400, "height": 1000})
        _one_method(page)
        page.locator("#auto-transcribe input[type=checkbox]").uncheck()
        _upload(page, speeches[0])
        page.evaluate("() => window.scrollTo(0, 0)")
        page.locator("#generate").scroll_into_view_if_needed()
        page.evaluate(WATCH_BUSY)
        page.locator("#generate").click()
        # the request's progress: on the status line alone, its box marked without Gradio's endless pulse (which
        # redrew the boxes all the while: gesturelsm/webapp/layout.py); every busy box is recorded as it appears, so a
        # short request on a loaded machine is seen too
        page.wait_for_function("() => window.busySeen.length > 0", timeout=60000)
        page.wait_for_function(IN_VIEW_JS, timeout=10000)                 # the player and its status, in view
        page.wait_for_function("() => document.querySelector('#generate-status').innerText.trim().length > 0",
                               timeout=60000)
        page.wait_for_selector(f"{PLAYER}[data-state=playing]", timeout=180000)
        assert page.evaluate(IN_VIEW_JS)
        page.wait_for_function("() => /made|Ready/.test(document.querySelector('#generate-status').innerText)",
                               timeout=60000)
        busy = page.evaluate("() => window.busySeen")
        assert busy == [["generate-status", "none"]], busy
        first = page.evaluate("() => window.gesturelsmPlayer.payload")

        page.locator("#edit-run").wait_for(state="visible", timeout=30000)
        for elem_id, value in (("edit-start", 1), ("edit-end", 2.5)):
            box = page.locator(f"#{elem_id} input")
            box.fill(str(value))
            box.press("Enter")
            box.blur()
        page.wait_for_selector(f"{PLAYER}[data-edit-start='1'][data-edit-end='2.5']", timeout=10000)
        band = page.evaluate(BAND_JS)
        assert band["display"] != "none" and band["width"] > 5, band       # drawn while the range is set
        page.locator("#edit-run").click()
        page.wait_for_function(f"() => window.gesturelsmPlayer.payload.id !== '{first['id']}'", timeout=120000)
        page.wait_for_selector(f"{PLAYER}[data-edit-start='1']", timeout=10000)
        band = page.evaluate(BAND_JS)
        assert band["display"] != "none" and band["width"] > 5, band       # and after the edit


@pytest.mark.browser
def test_tables_fit_their_column_or_scroll_and_the_idle_body_stands(page_url, speeches):
    with player_page(page_url, PLAYER) as page:
        idle = page.evaluate("""() => { const b = window.gesturelsmPlayer.idleBody;
            const y = (j) => b.bones[j].getWorldPosition(b.bones[j].position.clone()).y;
            return b && {feet: Math.min(y(10), y(11)), head: y(15), wrist: y(20), shoulder: y(16)}; }""")
        assert idle is not None, "the idle body is shown before any speech"
        assert 0 <= idle["feet"] < 0.15 and idle["head"] > 1.3, idle          # standing on the floor, whole
        assert idle["wrist"] < idle["shoulder"] - 0.3, idle                   # arms down, not a T-pose
        _one_method(page)
        page.locator("#auto-transcribe input[type=checkbox]").uncheck()
        _upload(page, speeches[1])
        _generated(page)
        page.wait_for_selector("#motion-stats[data-state=ready]", timeout=120000)
        page.get_by_role("tab", name="Sweep").click()
        _upload(page, speeches[1], "#sweep-speech")
        page.locator("#sweep-auto-transcribe input[type=checkbox]").uncheck()
        page.locator("#sweep-steps input, #sweep-steps textarea").first.fill("2 4")
        page.locator("#sweep-cfg input, #sweep-cfg textarea").first.fill("1.5")
        page.locator("#sweep-run").click()
        page.wait_for_selector("#sweep-table[data-state=ready]", timeout=300000)
        for w, h in ((1280, 800), (1920, 1080)):
            page.set_viewport_size({"width": w, "height": h})
            page.evaluate("() => new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")  # laid out
            tables = page.evaluate(TABLES_JS, list(TABLE_BOXES))
            assert {t["box"] for t in tables} == set(TABLE_BOXES), tables
            for t in tables:
                assert not t["cut"], f"{w}x{h}: the table in {t['box']} is cut ({t})"
                assert not t["broken"], f"{w}x{h}: headings of {t['box']} break inside words: {t['broken']}"
            timing = next(t for t in tables if t["box"] == "#timings")
            assert not timing["scrolls"], f"{w}x{h}: every stage of the timing table is in view ({timing})"
