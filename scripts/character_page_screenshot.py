"""A picture of the page with a character chosen: the in-browser player showing each method on it.

    .venv/bin/python scripts/character_page_screenshot.py ../shared/assets/characters/cryptovoxels.vrm \
        --out docs/character_page.png [--checkpoints DIR] [--example hello] [--seek 1.5]

Serves the app on the shipped (or given) checkpoints, uploads the character into `#character`, generates from an
example of the page, pauses the player at `--seek` seconds and saves the upper part of the page as a 256-colour PNG.
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


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("character", help=".vrm / .glb / .gltf")
    p.add_argument("--out", default="docs/character_page.png")
    p.add_argument("--checkpoints")
    p.add_argument("--example", default="hello", help="name of a file in gesturelsm/webapp/examples (without .wav)")
    p.add_argument("--chromium", default="/usr/lib/chromium/chromium")
    p.add_argument("--seek", type=float, default=1.5, help="show the player at this second")
    p.add_argument("--width", type=int, default=1100, help="width of the saved picture (pixels)")
    args = p.parse_args(argv)
    from PIL import Image
    from playwright.sync_api import sync_playwright

    from app.screenshot import CHROMIUM_ARGS
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.service import GestureService
    from gesturelsm.webapp.ui import EXAMPLES, serve_locally

    text = {m["audio"]: m["text"] for m in json.loads((EXAMPLES / "examples.json").read_text())}[f"{args.example}.wav"]
    service = GestureService.from_settings(ServiceSettings(checkpoints=args.checkpoints))
    demo, url = serve_locally(service)
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=args.chromium, args=CHROMIUM_ARGS)
            page = browser.new_page(viewport={"width": 1400, "height": 1000})
            page.goto(url)
            page.wait_for_selector("#motion-player[data-ready]", timeout=60000)
            page.locator("#character input[type=file]").set_input_files(args.character)
            page.locator("#character", has_text="humanoid bones").wait_for(timeout=60000)
            page.locator("#speech input[type=file]").first.set_input_files(str(EXAMPLES / f"{args.example}.wav"))
            page.locator("#transcript textarea").fill(text)
            page.locator("#speech [data-testid=download-link]").wait_for(state="attached", timeout=30000)
            page.locator("#generate").click()
            page.wait_for_selector("#motion-player[data-state=playing][data-character]", timeout=300000)
            page.evaluate("(t) => { window.gesturelsmPlayer.pause(); window.gesturelsmPlayer.seek(t); }", args.seek)
            page.evaluate("window.scrollTo(0, 0)")
            page.wait_for_timeout(1500)
            page.screenshot(path=args.out)
            browser.close()
    finally:
        demo.close()
    im = Image.open(args.out).convert("RGB")
    im = im.resize((args.width, round(im.height * args.width / im.width)), Image.LANCZOS)
    im.quantize(256).save(args.out, optimize=True)
    print(f"wrote {args.out} ({Path(args.out).stat().st_size // 1024} KB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
