"""A picture of the page after one generation, taken with headless Chromium (Debian's package).

    .venv/bin/python -m app.screenshot --out /tmp/gesturelsm_page.png [--checkpoints DIR] [--example hello]
"""
from __future__ import annotations

import os

os.environ["GRADIO_ANALYTICS_ENABLED"] = "False"
os.environ["HF_HUB_DISABLE_TELEMETRY"] = "1"

import argparse
import json
import time

CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-quic", "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--autoplay-policy=no-user-gesture-required",
                 "--use-angle=swiftshader", "--enable-unsafe-swiftshader"]


def show_video(page, timeout_ms: float = 300000) -> None:
    """Wait until the page says the server's mp4 is ready, open its accordion (the page keeps it closed,
    gesturelsm/webapp/ui.py), and wait for the <video> element."""
    page.wait_for_function("() => (document.querySelector('#summary') || {}).innerText?.includes('Video ready')",
                           timeout=timeout_ms)
    if page.locator("#video-box").count() and not page.locator("#video").count():
        page.locator("#video-box").get_by_text("Video with the speech").click()
    page.locator("#video video").wait_for(timeout=30000)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default="/tmp/gesturelsm_page.png")
    p.add_argument("--checkpoints")
    p.add_argument("--example", default="hello", help="name of a file in gesturelsm/webapp/examples (without .wav)")
    p.add_argument("--chromium", default="/usr/lib/chromium/chromium")
    p.add_argument("--seek", type=float, default=2.0, help="show the video at this second")
    args = p.parse_args(argv)
    from playwright.sync_api import sync_playwright

    # lazy: the service loads torch, .ui imports gradio; only once the arguments are read
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.service import GestureService

    from gesturelsm.webapp.ui import EXAMPLES, serve_locally

    text = {m["audio"]: m["text"] for m in json.loads((EXAMPLES / "examples.json").read_text())}[f"{args.example}.wav"]
    service = GestureService.from_settings(ServiceSettings(checkpoints=args.checkpoints))
    service.warmup()
    demo, url = serve_locally(service)
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=args.chromium, args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": 1400, "height": 1300})
        page.goto(url)
        page.locator("#speech input[type=file]").first.set_input_files(str(EXAMPLES / f"{args.example}.wav"))
        page.locator("#transcript textarea").fill(text)
        page.locator("#speech [data-testid=download-link]").wait_for(state="attached", timeout=30000)
        t0 = time.perf_counter()
        page.locator("#generate").click()
        show_video(page)
        print(f"video shown {time.perf_counter() - t0:.1f} s after the click")
        page.locator("#downloads a").first.wait_for(timeout=120000)
        page.evaluate("""async (t) => { const v = document.querySelector('#video video');
            if (v.readyState < 2) await new Promise(r => v.addEventListener('loadeddata', r, {once: true}));
            v.currentTime = t; await new Promise(r => setTimeout(r, 800)); }""", args.seek)
        page.locator("#view3d-show").click()                                # mount the GLB viewer
        page.locator("#view3d canvas").scroll_into_view_if_needed(timeout=30000)  # WebGL draws only on screen
        page.wait_for_timeout(3000)
        page.evaluate("window.scrollTo(0, 0)")
        page.wait_for_timeout(1500)
        page.screenshot(path=args.out, full_page=True)
        browser.close()
    demo.close()
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
