"""What a visitor of the page waits for, measured in real headless Chromium (SwiftShader WebGL, the floor):
click on "Generate" -> the in-browser player plays (`#motion-player[data-state=playing]`, as Playwright sees it, polling
on every animation frame, and on the page's own clock), the player's frame
rate in the first second of play, then while the server renders the mp4 and the speech plays (up to 10 s), and after (server idle), audio-motion offset when scrubbing, click -> mp4 shown, and
generating again with another seed on the same page (the bodies are replaced), once after the video and once while it
renders. Shipped checkpoints, eSpeak NG
speech (as app/measure.py), audio only, steps 8, DDIM 20, CFG 2, tiles 384. Each case runs --repeat times, every run
transcribing its upload afresh; prints a markdown table of medians. The page is opened with the player's measurement
hooks on (`?measure=1`, gesturelsm/webapp/player/src/measure.js): its load marks and the split of its draws.

    .venv/bin/python benchmarks/player_latency.py [--seconds 10 60] [--methods 1 3] [--checkpoints DIR] [--think-s 3]
                                                  [--repeat 3] [--character avatar.vrm]

With --character PATH every case runs twice per repeat, on the mannequin and with PATH chosen in the page's Character
upload (then "playing" also waits for `#motion-player[data-character]`), interleaved so both see the same load.
"""
from __future__ import annotations

import os

os.environ["GRADIO_ANALYTICS_ENABLED"] = "False"
os.environ["HF_HUB_DISABLE_TELEMETRY"] = "1"

import sys  # noqa: E402
import argparse  # noqa: E402
import json  # noqa: E402
import re  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from statistics import median  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))   # app/measure.py lives in the checkout, not the wheel

ALL = ["gesturelsm", "rectified_flow", "ddim"]
LABELS = {"gesturelsm": "GestureLSM", "rectified_flow": "Rectified flow", "ddim": "DDIM"}
PLAYER = "#motion-player"


def fps(page, seconds: float = 2.0) -> float:
    """Motion frames drawn per second by the player over `seconds` (data-frames counts them)."""
    n0 = int(page.get_attribute(PLAYER, "data-frames"))
    t0 = time.perf_counter()
    page.wait_for_timeout(seconds * 1000)
    return (int(page.get_attribute(PLAYER, "data-frames")) - n0) / (time.perf_counter() - t0)


def fps_while(page, js: str, max_s: float = 10.0) -> float:
    """Motion frames drawn per second while `js` (an expression) is true in the page, over at most max_s seconds."""
    n0, t0 = int(page.get_attribute(PLAYER, "data-frames")), time.perf_counter()
    while time.perf_counter() - t0 < max_s and page.evaluate(f"() => Boolean({js})"):
        page.wait_for_timeout(250)
    return (int(page.get_attribute(PLAYER, "data-frames")) - n0) / (time.perf_counter() - t0)


def scrub_offset(page, times=(0.5, 1.7, 3.2, 0.9)) -> float:
    """Largest |frame shown - audio time * fps| (frames) after seeking the player's clock while paused."""
    worst = 0.0
    page.evaluate("() => window.gesturelsmPlayer.pause()")
    for t in times:
        r = page.evaluate("""async (t) => { const p = window.gesturelsmPlayer, n = Number(p.element.dataset.frames);
            p.seek(t);                                   // then wait for the next draw (a new frame index)
            while (Number(p.element.dataset.frames) === n) await new Promise(r => setTimeout(r, 20));
            return [Number(p.element.dataset.frame), p.clock.currentTime * p.fps]; }""", t)
        worst = max(worst, abs(r[0] - int(r[1])))
    return worst


def click_and_wait(page, timeout_s: float = 600, on: str | None = None) -> tuple[float, dict]:
    """Click generate; seconds until the player plays the new motion (on the character file `on`, when given), and
    the player's own marks (ms)."""
    page.evaluate(f"() => {{ delete document.querySelector('{PLAYER}').dataset.marks; }}")
    click_ms = page.evaluate("() => performance.now()")
    t0 = time.perf_counter()
    page.locator("#generate").click()
    # polled on every animation frame: wait_for_selector's polling backs off to 500 ms and added 0.3-0.5 s
    sel = f"{PLAYER}[data-marks][data-state=playing]" + (f"[data-character={json.dumps(on)}]" if on else "")
    page.wait_for_function(f"() => document.querySelector({json.dumps(sel)}) !== null",
                           polling="raf", timeout=timeout_s * 1000)
    marks = json.loads(page.get_attribute(PLAYER, "data-marks"))
    marks["payload"] = (marks["start"] - click_ms) / 1000                 # click -> payload in the page (s)
    marks["page_play"] = marks["payload"] + marks["play"] / 1000        # click -> playing on the page's own clock
    return time.perf_counter() - t0, marks


def downloads(page) -> str:
    return page.evaluate("() => [...document.querySelectorAll('#downloads a')].map((a) => a.href).join(' ')")


def downloads_changed(old: str) -> str:
    return ("() => { const h = [...document.querySelectorAll('#downloads a')].map((a) => a.href).join(' '); "
            f"return h && h !== {old!r}; }}")


def run_case(browser, url: str, wav: Path, methods: list[str], think_s: float = 0.0, workdir: Path = Path("."),
             character: Path | None = None) -> dict:
    page = browser.new_page(viewport={"width": 1400, "height": 1300})
    page.goto(f"{url}?measure=1")                      # the player's marks (data-marks) and draw split (prof)
    page.wait_for_selector(f"{PLAYER}[data-ready]", timeout=60000)
    if character is not None:                          # chosen before the speech, as a visitor would
        page.locator("#character input[type=file]").set_input_files(str(character))
        page.locator("#character", has_text="humanoid bones").wait_for(timeout=120000)
    for m in ALL:
        if m not in methods:
            page.locator("#methods label", has_text=LABELS[m]).click()
    page.locator("#speech input[type=file]").first.set_input_files(str(wav))
    page.locator("#speech [data-testid=download-link]").wait_for(state="attached", timeout=30000)
    page.wait_for_timeout(think_s * 1000)             # a visitor choosing settings (the upload is being transcribed)
    t0 = time.perf_counter()
    play_s, marks = click_and_wait(page, on=Path(character).name if character is not None else None)
    r = {"play": play_s, "marks": marks, "fps_first": fps(page, 1.0)}
    rendering = ("!document.querySelector('#summary').innerText.includes('Video ready') && "
                 f"document.querySelector('{PLAYER}').dataset.state === 'playing'")
    r["fps_render"] = fps_while(page, rendering)     # until the mp4 is ready or the speech is over (<= 10 s)
    page.wait_for_function("() => document.querySelector('#summary').innerText.includes('Video ready')",
                           timeout=900000)                        # the page says so; the video opens on request
    r["mp4"] = time.perf_counter() - t0
    page.locator("#downloads a").first.wait_for(timeout=300000)          # the chain is over: the server idles
    page.evaluate("() => { const p = window.gesturelsmPlayer; p.seek(0); p.play(); }")
    page.wait_for_timeout(300)
    page.evaluate("() => { const p = window.gesturelsmPlayer; if (p.prof) for (const k in p.prof) p.prof[k] = 0; }")
    r["fps_idle"] = fps(page)
    r["prof"] = page.evaluate("() => window.gesturelsmPlayer.prof || null")   # ms per part, draws after
    r["scrub"] = scrub_offset(page)
    old = downloads(page)
    page.get_by_label("Seed").fill("7")
    r["again"], _ = click_and_wait(page)
    page.wait_for_function(downloads_changed(old), timeout=900000)  # the chain is over again
    old = downloads(page)
    page.get_by_label("Seed").fill("8")                # its video renders; meanwhile the visitor changes the seed
    click_and_wait(page)
    r["rendering"] = not page.evaluate("() => document.querySelector('#summary').innerText.includes('Video ready')")
    page.get_by_label("Seed").fill("9")
    r["again_rendering"], _ = click_and_wait(page)
    folder = re.search(r"req-[0-9a-f]+", page.evaluate("() => window.gesturelsmPlayer.payload.bodies[0].motion"))[0]
    exported = workdir / folder / f"{methods[0]}_keypoints.json"    # the newest request's last download
    t_end = time.perf_counter() + 900
    while not exported.exists() and time.perf_counter() < t_end:
        page.wait_for_timeout(250)
    page.wait_for_function(downloads_changed(old), timeout=60000)   # and the page shows them
    page.close()
    return r


def per_draw(prof: dict | None) -> str:
    """The player's own split of a draw (ms, mean over the draws counted), or n/a for a bundle without it."""
    if not prof or not prof.get("draws"):
        return "n/a"
    return " / ".join(f"{prof[k] / prof['draws']:.1f}" for k in ("pose", "render", "labels", "dom"))


def row(dur: float, n: int, body: str, runs: list[dict]) -> None:
    """One line of the table: medians over `runs`."""
    r = {k: median([x[k] for x in runs]) for k in ("play", "fps_first", "fps_render", "fps_idle", "scrub",
                                                  "mp4", "again", "again_rendering")}
    busy = sum(x["rendering"] for x in runs)
    m = {k: median([x["marks"].get(k, 0) for x in runs]) for k in ("page_play", "payload", "bodies",
                                                                   "motion", "play")}
    spread = f" ({min(x['play'] for x in runs):.2f}-{max(x['play'] for x in runs):.2f})" if len(runs) > 1 else ""
    print(f"| {dur:.1f} s | {n} | {body} | {r['play']:.2f}{spread} | {m['page_play']:.2f} | {m['payload']:.2f} | "
          f"{m['bodies']:.0f} / {m['motion']:.0f} / {m['play']:.0f} | {r['fps_first']:.1f} | "
          f"{r['fps_render']:.1f} | {r['fps_idle']:.1f} | {per_draw(runs[-1]['prof'])} | {r['scrub']:.0f} | "
          f"{r['mp4']:.1f} | {r['again']:.2f} | {r['again_rendering']:.2f} ({busy}/{len(runs)}) |",
          flush=True)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seconds", type=float, nargs="+", default=[10, 60])
    p.add_argument("--methods", type=int, nargs="+", default=[1, 3], choices=[1, 2, 3])
    p.add_argument("--checkpoints")
    p.add_argument("--think-s", type=float, default=0.0,
                   help="seconds between the upload and the click (0: click at once, the worst case)")
    p.add_argument("--repeat", type=int, default=3, help="runs per case; the table gives medians (and the range of "
                   "click -> playing)")
    p.add_argument("--chromium", default="/usr/lib/chromium/chromium")
    p.add_argument("--character", type=Path, metavar="PATH",
                   help="also run every case with this character chosen in the page (.vrm / .glb / .gltf)")
    args = p.parse_args(argv)
    if args.character is not None and not args.character.is_file():
        p.error(f"--character {args.character}: no such file")
    import torch
    from playwright.sync_api import sync_playwright

    from app.measure import speech
    from app.screenshot import CHROMIUM_ARGS
    from gesturelsm.webapp.ui import serve_locally
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.service import GestureService
    from gesturelsm.asr.source import RECENT

    torch.set_num_threads(1)
    service = GestureService.from_settings(ServiceSettings(checkpoints=args.checkpoints, max_seconds=600))
    service.warmup()
    demo, url = serve_locally(service)
    print("| speech | methods | body | click -> playing (s), median (range) | same, page clock (s) | click -> payload in the page (s) | then bodies / motion / "
          "playing (ms) | "
          "player fps, first second | player fps while the mp4 renders (next <= 10 s) | player fps after (server idle) | ms per draw after: pose / render / labels / dom | scrub offset (frames) | click -> mp4 (s) | "
          "again, new seed -> playing (s) | again while the mp4 renders -> playing (s) (runs where it still rendered) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp, sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=args.chromium, args=CHROMIUM_ARGS)
        for sec in args.seconds:
            wav, _, dur = speech(sec, Path(tmp) / f"speech_{int(sec)}.wav")
            for n in args.methods:
                bodies = [None] + ([args.character] if args.character is not None else [])
                cases = {b: [] for b in bodies}
                for _ in range(args.repeat):
                    for b in bodies:
                        RECENT.clear()               # every run transcribes its upload afresh, as a new visitor's
                        cases[b].append(run_case(browser, url, wav, ALL[:n], args.think_s, service.workdir, b))
                for b, runs in cases.items():
                    row(dur, n, "mannequin" if b is None else b.name, runs)
        browser.close()
    demo.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
