"""A visitor's video behind another visitor who closed the tab mid-render, against the same video alone, in real
headless Chromium on one served page (`python -m app` of this checkout, shipped checkpoints, one video at a time).

    .venv/bin/python benchmarks/render_queue.py [--rounds 3] [--long 60] [--short 5]

Each round runs two cases, in turn (A B, then B A, ...), so that load from other processes hits both alike:
- alone: a session uploads --short seconds of speech and clicks Generate; nothing else runs;
- behind a closed tab: session 1 generates --long seconds and is closed once its video has rendered its first
  frames (the summary shows "frame k/n"); session 2 then does what "alone" does.
For session 2 it times the click -> every download offered (npz, BVH, GLB, keypoints, ARKit CSV) and click -> the
mp4 in the page. The bar: the mp4 behind a closed tab within 2x of the mp4 alone (medians), and the files before the
video in both. Speech: the held-out BEAT2 take 2_scott_0_2_2 cut to length, audio only (no transcription: its time
would be the same in both cases), GestureLSM alone, the page's other defaults.
"""
from __future__ import annotations

import os

os.environ["GRADIO_ANALYTICS_ENABLED"] = "False"
os.environ["HF_HUB_DISABLE_TELEMETRY"] = "1"

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

from _harness import REPO, Rows, take_wav
from _served import served_app

sys.path.insert(0, str(REPO))                      # app/screenshot.py: the browser's flags

FILES = ("gesturelsm.npz", "gesturelsm.bvh", "gesturelsm.glb", "gesturelsm_keypoints.json", "gesturelsm_arkit.csv")
# the time (performance.now) at which every download is offered and at which the video's file is in the page
WATCH_JS = r"""(files) => { window.__at = {};
    window.__watch = setInterval(() => {
        const names = [...document.querySelectorAll('#downloads .filename')]
            .map((td) => td.textContent.replace(/\s+/g, ''));
        if (!window.__at.files && files.every((f) => names.includes(f))) window.__at.files = performance.now();
        const v = document.querySelector('#video video');
        if (!window.__at.video && v && v.getAttribute('src')) window.__at.video = performance.now();
    }, 20); }"""
RENDERING = ("() => /Rendering the video \\(mp4\\): frame [1-9]\\d*\\//.test("
             "document.querySelector('#summary').innerText)")


def cut(seconds: float, folder: Path) -> Path:
    import soundfile as sf

    audio, sr = sf.read(take_wav("2_scott_0_2_2"))
    out = folder / f"speech_{seconds:g}s.wav"
    sf.write(out, audio[: int(seconds * sr)], sr)
    return out


def open_page(browser, url: str):
    page = browser.new_page(viewport={"width": 1400, "height": 1300})
    page.goto(url)
    page.locator("#generate").wait_for(timeout=120000)
    if page.locator("#video-box").count() and not page.locator("#video").count():
        page.locator("#video-box").get_by_text("Video with the speech").click()
    for name in ("DDIM", "Rectified flow"):                                  # GestureLSM alone
        box = page.locator("#methods label", has_text=name)
        if box.count() and box.locator("input").is_checked():
            box.click()
    page.locator("#auto-transcribe input[type=checkbox]").uncheck()
    return page


def upload(page, wav: Path) -> None:
    page.locator("#speech input[type=file]").first.set_input_files(str(wav))
    page.locator("#speech [data-testid=download-link]").wait_for(state="attached", timeout=120000)


def visitor(browser, url: str, wav: Path) -> tuple[float, float]:
    """Seconds from the click to every download offered and to the mp4 in the page, for one session."""
    page = open_page(browser, url)
    try:
        page.evaluate(WATCH_JS, list(FILES))
        upload(page, wav)
        clicked = page.evaluate("() => performance.now()")
        page.locator("#generate").click()
        page.wait_for_function("() => window.__at.video && window.__at.files", timeout=1200000)
        at = page.evaluate("() => window.__at")
        return (at["files"] - clicked) / 1000, (at["video"] - clicked) / 1000
    finally:
        page.close()


def closer(browser, url: str, wav: Path) -> None:
    """Session 1: generate `wav` and close the tab once its video has rendered its first frames."""
    page = open_page(browser, url)
    upload(page, wav)
    page.locator("#generate").click()
    page.wait_for_function(RENDERING, timeout=1200000)
    page.close()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--long", type=float, default=60.0)
    ap.add_argument("--short", type=float, default=5.0)
    args = ap.parse_args()
    times: dict[str, list[tuple[float, float]]] = {"alone": [], "behind a closed tab": []}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        long, short = cut(args.long, folder), cut(args.short, folder)
        (folder / "work").mkdir()
        try:
            run_rounds(args, folder, long, short, times)
        except Exception:
            for log in folder.glob("server-*.log"):                      # what the server said, before it goes
                print(f"--- {log.name} (last lines)\n" + "\n".join(log.read_text().splitlines()[-40:]),
                      file=sys.stderr)
            raise
    rows = Rows(["case", "click -> files, median s", "click -> mp4, median s", "mp4 runs s", "files before mp4"])
    for case, got in times.items():
        rows.add(case, f"{statistics.median(f for f, _ in got):.1f}", f"{statistics.median(v for _, v in got):.1f}",
                 ", ".join(f"{v:.1f}" for _, v in got), all(f <= v for f, v in got))
    print()
    print(rows.markdown())
    ratio = (statistics.median(v for _, v in times["behind a closed tab"])
             / statistics.median(v for _, v in times["alone"]))
    print(f"\nmp4 behind a closed tab / alone: {ratio:.2f} (bar <= 2.0); {args.rounds} rounds, "
          f"load average {os.getloadavg()[0]:.1f} at the end.")
    return 0


def run_rounds(args, folder: Path, long: Path, short: Path, times: dict) -> None:
    from playwright.sync_api import sync_playwright

    from app.screenshot import CHROMIUM_ARGS

    with served_app(REPO, folder / "work") as app, sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=chromium(), args=CHROMIUM_ARGS)
        try:
            visitor(browser, app.url, short)                             # warm: the first render pays set-up
            for r in range(args.rounds):
                for case in (("alone", "behind a closed tab") if r % 2 == 0 else
                             ("behind a closed tab", "alone")):
                    if case != "alone":
                        closer(browser, app.url, long)
                    times[case].append(visitor(browser, app.url, short))
                    print(f"  round {r + 1}, {case}: files {times[case][-1][0]:.1f} s, "
                          f"mp4 {times[case][-1][1]:.1f} s", flush=True)
        finally:
            browser.close()


def chromium() -> str:
    import shutil

    for name in ("/usr/lib/chromium/chromium", shutil.which("chromium"), shutil.which("chromium-browser")):
        if name and Path(name).exists():
            return name
    raise SystemExit("chromium is not installed (apt-get install chromium libatomic1; scripts/setup.sh does it)")


if __name__ == "__main__":
    sys.exit(main())
