"""Pictures of the page as a visitor meets it, at 1280x800 and 1920x1080 (docs/WEBAPP.md shows them).

    .venv/bin/python scripts/page_screenshots.py [--out docs] [--checkpoints DIR] [--example hello] \
        [--sizes 1280x800 1920x1080] [--no-sweep]

Serves the app on the shipped (or given) checkpoints and, for each window size, in headless Chromium: opens the page
(`page-idle-WxH.png`: the idle player before any speech), uploads an example with its transcript, clicks Generate
and saves what the window shows just after the click (`page-click-WxH.png`) and once every
method's body moves (`page-WxH.png`: the page brings the player and its
status into view), then the results column with the timings and statistics tables (`page-tables-WxH.png`); runs a
small sweep in the Sweep tab (`sweep-WxH.png`) and shows the Live tab before recording (`live-WxH.png`). For each
table in `#timings`, `#motion-stats-box` and `#sweep-table-box` it prints whether it fits its column or scrolls
inside it. Pictures are saved as 256-colour PNGs.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

os.environ.setdefault("GRADIO_ANALYTICS_ENABLED", "False")
os.environ.setdefault("HF_HUB_DISABLE_TELEMETRY", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

def save(page, path: Path, **kw) -> None:
    from PIL import Image

    page.screenshot(path=str(path), **kw)
    Image.open(path).convert("RGB").quantize(256).save(path, optimize=True)
    print(f"wrote {path} ({path.stat().st_size // 1024} KB)")


def report(page, size: str, boxes: list[str]) -> None:
    """Print, for each table in `boxes`, whether it fits its column, scrolls inside it or is cut, and any heading word
    broken across lines."""
    from gesturelsm.webapp.layout import TABLES_JS

    for t in page.evaluate(TABLES_JS, boxes):
        state = "CUT" if t["cut"] else "scrolls inside its column" if t["scrolls"] else "fits its column"
        broken = f"; words broken: {', '.join(t['broken'])}" if t["broken"] else "; no heading word broken"
        print(f"{size} {t['box']}: {state} (table {t['width']} px){broken}")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default="docs", help="folder for the pictures")
    p.add_argument("--checkpoints")
    p.add_argument("--example", default="hello", help="name of a file in gesturelsm/webapp/examples (without .wav)")
    p.add_argument("--chromium", default="/usr/lib/chromium/chromium")
    p.add_argument("--sizes", nargs="+", default=["1280x800", "1920x1080"], help="window sizes, WIDTHxHEIGHT")
    p.add_argument("--seek", type=float, default=1.5, help="show the player at this second")
    p.add_argument("--no-sweep", action="store_true", help="skip the Sweep tab's pictures")
    args = p.parse_args(argv)
    from playwright.sync_api import sync_playwright

    from app.screenshot import CHROMIUM_ARGS
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.service import GestureService
    from gesturelsm.webapp.ui import EXAMPLES, serve_locally

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    wav = EXAMPLES / f"{args.example}.wav"
    text = {m["audio"]: m["text"] for m in json.loads((EXAMPLES / "examples.json").read_text())}[wav.name]
    service = GestureService.from_settings(ServiceSettings(checkpoints=args.checkpoints))
    demo, url = serve_locally(service)
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=args.chromium, args=CHROMIUM_ARGS)
            for size in args.sizes:
                w, h = map(int, size.split("x"))
                page = browser.new_page(viewport={"width": w, "height": h})
                page.goto(url)
                page.wait_for_selector("#motion-player[data-ready]", timeout=120000)
                page.wait_for_timeout(1000)
                save(page, out / f"page-idle-{size}.png")
                page.locator("#speech input[type=file]").first.set_input_files(str(wav))
                page.locator("#transcript textarea").fill(text)
                page.locator("#speech [data-testid=download-link]").wait_for(state="attached", timeout=30000)
                page.locator("#generate").click()
                page.wait_for_function("() => document.querySelector('#generate-status').innerText.trim()",
                                       timeout=60000)
                save(page, out / f"page-click-{size}.png")      # just after the click: the status says the stage
                page.wait_for_selector("#motion-player[data-state=playing]", timeout=300000)
                page.wait_for_function("() => document.querySelector('#motion-player').dataset.bodies === "
                                       "String(window.gesturelsmPlayer.bodies.length)", timeout=300000)
                page.wait_for_selector("#motion-stats[data-state=ready]", timeout=120000)
                page.evaluate("(t) => { window.gesturelsmPlayer.pause(); window.gesturelsmPlayer.seek(t); }", args.seek)
                page.wait_for_timeout(1000)
                save(page, out / f"page-{size}.png")
                page.locator("#timings").scroll_into_view_if_needed()
                page.wait_for_timeout(500)
                save(page, out / f"page-tables-{size}.png")
                report(page, size, ["#timings", "#motion-stats-box"])
                if not args.no_sweep:
                    page.get_by_role("tab", name="Sweep").click()
                    page.locator("#sweep-speech input[type=file]").first.set_input_files(str(wav))
                    page.locator("#sweep-text textarea").fill(text)
                    page.locator("#sweep-speech [data-testid=download-link]").wait_for(state="attached", timeout=30000)
                    page.locator("#sweep-steps textarea, #sweep-steps input").first.fill("2 4")
                    page.locator("#sweep-cfg textarea, #sweep-cfg input").first.fill("1.5")
                    page.locator("#sweep-run").click()
                    page.wait_for_selector("#sweep-table[data-state=ready]", timeout=300000)
                    page.locator("#sweep-table-box").scroll_into_view_if_needed()
                    page.wait_for_timeout(500)
                    save(page, out / f"sweep-{size}.png")
                    report(page, size, ["#sweep-table-box"])
                if page.get_by_role("tab", name="Live").count():
                    page.get_by_role("tab", name="Live").click()
                    page.wait_for_timeout(2000)
                    page.locator("#live-player-box").scroll_into_view_if_needed()
                    page.wait_for_timeout(1000)
                    save(page, out / f"live-{size}.png")
                page.close()
            browser.close()
    finally:
        demo.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
