"""What a visitor of the page waits for, measured in real headless Chromium (SwiftShader WebGL, the floor):
click on "Generate" -> the first body moves (`#motion-player[data-state=playing]`, as Playwright sees it, polling on
every animation frame) and all bodies move (`data-bodies` = the number of methods; a page without that attribute
moves them all at once), the motion frames drawn in the first 2 s after that, click -> the payload in the page and
click -> the first payload with motion in it handed to the player (the player's own marks: before it the server's
part, after it the browser's fetch, decode and first draw), the player's frame rate while the server renders the mp4
and the speech plays (up to 10 s), click -> mp4 (--quick stops before these); without --quick also the frame rate
after (server idle), the audio-motion offset when scrubbing, and generating again with another seed on the same page
(the bodies are replaced), once after the video and once while it renders. Shipped checkpoints, eSpeak NG speech (as
app/measure.py), audio only, steps 8, DDIM 20, CFG 2, tiles 384.

    .venv/bin/python benchmarks/player_latency.py [--seconds 10 60] [--methods 1 3] [--think-s 3] [--repeat 3]
                                                  [--vs /path/to/other/checkout] [--quick] [--character avatar.vrm]
                                                  [--without-ahead] [--new-seed] [--json FILE]

The page is the checkout's own `python -m app` in a process of its own (benchmarks/_served.py: its warm-up, its
math threads), opened with the player's measurement hooks on (`?measure=1`, gesturelsm/webapp/player/src/measure.js).
Each case runs --repeat times, each run on speech of its own content (the server transcribes every upload afresh);
the table gives medians. --vs CHECKOUT serves that checkout's page too (e.g. a worktree of main: before / after) and
alternates the two run by run, so both see the same minutes of a shared machine. With --character PATH every case
runs twice per repeat, on the mannequin and with PATH chosen in the page's Character upload (then "playing" also
waits for `#motion-player[data-character]`), interleaved the same way. --think-s: seconds between the upload and
the click (0: at once, so the click also waits for the work the upload started). The page makes the motion of the
settings it shows while the visitor thinks (gesturelsm/serve/ahead.py): --without-ahead serves this checkout a second
time with --no-ahead (interleaved the same way), and --new-seed types another seed right before each click, so the
click asks for other motion than the one made ahead (the server starts on it when the seed changes). --json FILE also
writes the table there. The page's server sets its own math threads (as `python -m app` does); this process runs no
model code.
"""
from __future__ import annotations

import os

os.environ["GRADIO_ANALYTICS_ENABLED"] = "False"
os.environ["HF_HUB_DISABLE_TELEMETRY"] = "1"

import sys
import argparse
import contextlib
import json
import re
import tempfile
from statistics import median
from pathlib import Path

from _harness import REPO, Rows, Stopwatch, json_flag, save_json

sys.path.insert(0, str(REPO))                  # app/measure.py lives in the checkout, not the wheel

ALL = ["gesturelsm", "rectified_flow", "ddim"]
LABELS = {"gesturelsm": "GestureLSM", "rectified_flow": "Rectified flow", "ddim": "DDIM"}
PLAYER = "#motion-player"


def fps(page, seconds: float = 2.0) -> float:
    """Motion frames drawn per second by the player over `seconds` (data-frames counts them)."""
    n0 = int(page.get_attribute(PLAYER, "data-frames"))
    with Stopwatch() as sw:
        page.wait_for_timeout(seconds * 1000)
    return (int(page.get_attribute(PLAYER, "data-frames")) - n0) / sw.seconds


def fps_while(page, js: str, max_s: float = 10.0) -> float:
    """Motion frames drawn per second while `js` (an expression) is true in the page, over at most max_s seconds."""
    n0 = int(page.get_attribute(PLAYER, "data-frames"))
    with Stopwatch() as sw:
        while sw.elapsed < max_s and page.evaluate(f"() => Boolean({js})"):
            page.wait_for_timeout(250)
    return (int(page.get_attribute(PLAYER, "data-frames")) - n0) / sw.seconds


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


ALL_MOVING = ("(e) => e.dataset.state === 'playing' && (e.dataset.bodies === undefined || "
              "Number(e.dataset.bodies) >= {n})")       # a page without data-bodies moves them all at once


def click_and_wait(page, n: int, timeout_s: float = 600, on: str | None = None) -> tuple[float, float, dict]:
    """Click generate; seconds until the player moves the first body of the new motion (data-state playing; on the
    character file `on`, when given) and until all `n` move (data-bodies), and the player's own marks (ms)."""
    page.evaluate(f"() => {{ delete document.querySelector('{PLAYER}').dataset.marks; }}")
    click_ms = page.evaluate("() => performance.now()")
    with Stopwatch() as sw:
        page.locator("#generate").click()
        # polled on every animation frame: wait_for_selector's polling backs off to 500 ms and added 0.3-0.5 s
        sel = f"{PLAYER}[data-marks][data-state=playing]" + (f"[data-character={json.dumps(on)}]" if on else "")
        page.wait_for_function(f"() => document.querySelector({json.dumps(sel)}) !== null",
                               polling="raf", timeout=timeout_s * 1000)
        first = sw.elapsed
        page.wait_for_function(f"() => ({ALL_MOVING.format(n=n)})(document.querySelector('{PLAYER}'))",
                               polling="raf", timeout=timeout_s * 1000)
    every = sw.seconds
    marks = json.loads(page.get_attribute(PLAYER, "data-marks"))
    marks["payload"] = (marks["start"] - click_ms) / 1000                 # click -> first payload in the page (s)
    marks["page_play"] = marks["payload"] + marks["play"] / 1000        # click -> playing on the page's own clock
    return first, every, marks


def downloads(page) -> str:
    return page.evaluate("() => [...document.querySelectorAll('#downloads a')].map((a) => a.href).join(' ')")


def downloads_changed(old: str) -> str:
    return ("() => { const h = [...document.querySelectorAll('#downloads a')].map((a) => a.href).join(' '); "
            f"return h && h !== {old!r}; }}")


def frames_drawn(page, seconds: float) -> int:
    """Motion frames the player draws in the next `seconds` (data-frames counts them)."""
    n0 = int(page.get_attribute(PLAYER, "data-frames"))
    page.wait_for_timeout(seconds * 1000)
    return int(page.get_attribute(PLAYER, "data-frames")) - n0


def open_page(browser, url: str, wav: Path, methods: list[str], character: Path | None):
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
    return page


def run_case(browser, url: str, wav: Path, methods: list[str], think_s: float = 0.0, workdir: Path = Path("."),
             character: Path | None = None, quick: bool = False, new_seed: bool = False) -> dict:
    page = open_page(browser, url, wav, methods, character)
    page.wait_for_timeout(think_s * 1000)             # a visitor choosing settings (the upload is being prepared)
    if new_seed:                                      # ... who types another seed and clicks at once
        page.get_by_label("Seed").fill("5")
    on = Path(character).name if character is not None else None
    with Stopwatch() as clock:                        # click -> mp4
        first, every, marks = click_and_wait(page, len(methods), on=on)
        r = {"play": first, "all": every, "marks": marks, "drawn2": frames_drawn(page, 2.0)}
        if quick:                                     # the mp4 renders on (niced: on a busy machine it waits long)
            page.close()
            return r
        rendering = ("!document.querySelector('#summary').innerText.includes('Video ready') && "
                     f"document.querySelector('{PLAYER}').dataset.state === 'playing'")
        r["fps_render"] = fps_while(page, rendering)  # until the mp4 is ready or the speech is over (<= 10 s)
        page.wait_for_function("() => document.querySelector('#summary').innerText.includes('Video ready')",
                               timeout=900000)                    # the page says so; the video opens on request
        r["mp4"] = clock.elapsed
    page.locator("#downloads a").first.wait_for(timeout=300000)          # the chain is over: the server idles
    page.evaluate("() => { const p = window.gesturelsmPlayer; p.seek(0); p.play(); }")
    page.wait_for_timeout(300)
    page.evaluate("() => { const p = window.gesturelsmPlayer; if (p.prof) for (const k in p.prof) p.prof[k] = 0; }")
    r["fps_idle"] = fps(page)
    r["prof"] = page.evaluate("() => window.gesturelsmPlayer.prof || null")   # ms per part, draws after
    r["scrub"] = scrub_offset(page)
    r.update(again(page, len(methods), workdir, methods[0]))
    page.close()
    return r


def again(page, n: int, workdir: Path, first_method: str) -> dict:
    """Generating again with another seed on the same page: after the chain is over, and while the mp4 renders."""
    r = {}
    old = downloads(page)
    page.get_by_label("Seed").fill("7")
    r["again"], _, _ = click_and_wait(page, n)
    page.wait_for_function(downloads_changed(old), timeout=900000)  # the chain is over again
    old = downloads(page)
    page.get_by_label("Seed").fill("8")                # its video renders; meanwhile the visitor changes the seed
    click_and_wait(page, n)
    r["rendering"] = not page.evaluate("() => document.querySelector('#summary').innerText.includes('Video ready')")
    page.get_by_label("Seed").fill("9")
    r["again_rendering"], _, _ = click_and_wait(page, n)
    folder = re.search(r"req-[0-9a-f]+", page.evaluate("() => window.gesturelsmPlayer.payload.bodies[0].motion"))[0]
    exported = workdir / folder / f"{first_method}_keypoints.json"    # the newest request's last download
    with Stopwatch() as sw:
        while not exported.exists() and sw.elapsed < 900:
            page.wait_for_timeout(250)
    page.wait_for_function(downloads_changed(old), timeout=60000)   # and the page shows them
    return r


def per_draw(prof: dict | None) -> str:
    """The player's own split of a draw (ms, mean over the draws counted), or n/a for a bundle without it."""
    if not prof or not prof.get("draws"):
        return "n/a"
    return " / ".join(f"{prof[k] / prof['draws']:.1f}" for k in ("pose", "render", "labels", "dom"))


HEADER = ["speech", "methods", "page", "body", "click -> first body moving (s), median (range)",
          "click -> all moving (s)", "frames drawn in the first 2 s", "click -> payload in the page (s)",
          "click -> first motion handed to the player (s)"]
FULL = ["player fps while the mp4 renders (next <= 10 s)", "click -> mp4 (s)", "player fps after (server idle)",
        "ms per draw after: pose / render / labels / dom", "scrub offset (frames)",
        "again, new seed -> playing (s)", "again while the mp4 renders -> playing (s) (runs where it still rendered)"]


def cells(dur: float, n: int, page: str, body: str, runs: list[dict], quick: bool) -> list[str]:
    """The cells of one line of the table: medians over `runs`."""
    med = lambda k: median([x[k] for x in runs])               # noqa: E731
    spread = f" ({min(x['play'] for x in runs):.2f}-{max(x['play'] for x in runs):.2f})" if len(runs) > 1 else ""
    payload = median([x["marks"].get("payload", 0) for x in runs])
    given = [x["marks"]["payload"] + x["marks"]["given"] / 1000 for x in runs if "given" in x["marks"]]
    out = [f"{dur:.1f} s", str(n), page, body, f"**{med('play'):.2f}**{spread}", f"{med('all'):.2f}",
           f"{med('drawn2'):.0f}", f"{payload:.2f}", f"{median(given):.2f}" if given else "n/a"]
    if not quick:
        busy = sum(x["rendering"] for x in runs)
        out += [f"{med('fps_render'):.1f}", f"{med('mp4'):.1f}", f"{med('fps_idle'):.1f}", per_draw(runs[-1]["prof"]),
                f"{med('scrub'):.0f}", f"{med('again'):.2f}", f"{med('again_rendering'):.2f} ({busy}/{len(runs)})"]
    return out


def unique_speech(wav: Path, k: int, out: Path) -> Path:
    """`wav` scaled by a gain a thousandth below the last run's: other content, so the server transcribes it afresh
    (it remembers transcripts by content), with the same words and length."""
    import soundfile as sf

    y, sr = sf.read(wav, dtype="float32")
    sf.write(out, y * (1.0 - 1e-3 * k), sr)
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seconds", type=float, nargs="+", default=[10, 60])
    p.add_argument("--methods", type=int, nargs="+", default=[1, 3], choices=[1, 2, 3])
    p.add_argument("--think-s", type=float, default=0.0,
                   help="seconds between the upload and the click (0: click at once, the worst case)")
    p.add_argument("--repeat", type=int, default=3, help="runs per case; the table gives medians (and the range of "
                   "click -> first body moving)")
    p.add_argument("--vs", type=Path, metavar="CHECKOUT", help="also serve the page of this checkout (e.g. a worktree "
                   "of main) and alternate the two run by run")
    p.add_argument("--quick", action="store_true", help="only the columns up to the payload: the next run starts "
                   "without waiting for the mp4 (no fps while it renders, idle fps, scrubbing or generating again)")
    p.add_argument("--without-ahead", action="store_true", help="also serve this checkout with --no-ahead (no motion "
                   "made before the click) and alternate it with the others run by run")
    p.add_argument("--new-seed", action="store_true", help="type another seed right before each click: the click asks "
                   "for other motion than the settings shown at the upload")
    p.add_argument("--chromium", default="/usr/lib/chromium/chromium")
    p.add_argument("--character", type=Path, metavar="PATH",
                   help="also run every case with this character chosen in the page (.vrm / .glb / .gltf)")
    json_flag(p)
    args = p.parse_args(argv)
    if args.character is not None and not args.character.is_file():
        p.error(f"--character {args.character}: no such file")
    from playwright.sync_api import sync_playwright

    from _served import served_app
    from app.measure import speech
    from app.screenshot import CHROMIUM_ARGS

    pages = [(REPO, "this checkout", ())] + ([(REPO, "this checkout, --no-ahead", ("--no-ahead",))]
                                            if args.without_ahead else []) \
        + ([(args.vs, f"{args.vs.name} (--vs)", ())] if args.vs else [])
    table = Rows(HEADER + ([] if args.quick else FULL))
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; think {args.think_s:g} s"
          f"{'; another seed typed right before the click' if args.new_seed else ''}; medians of {args.repeat}\n")
    with tempfile.TemporaryDirectory() as tmp, contextlib.ExitStack() as stack:
        tmp = Path(tmp)
        apps = []
        for i, (checkout, name, extra) in enumerate(pages):
            (tmp / f"app{i}").mkdir()
            apps.append(stack.enter_context(served_app(checkout, tmp / f"app{i}" / "work", name, extra=extra)))
        print(table.header(), flush=True)
        browser = stack.enter_context(sync_playwright()).chromium.launch(executable_path=args.chromium,
                                                                         args=CHROMIUM_ARGS)
        k = 0
        for sec in args.seconds:
            wav, _, dur = speech(sec, tmp / f"speech_{int(sec)}.wav")
            for n in args.methods:
                bodies = [None] + ([args.character] if args.character is not None else [])
                cases = {(a.name, b): [] for a in apps for b in bodies}
                for _ in range(args.repeat):
                    for a in apps:                       # interleaved: every page sees the same minutes of load
                        for b in bodies:
                            k += 1
                            run_wav = unique_speech(wav, k, tmp / f"run{k}.wav")
                            cases[(a.name, b)].append(run_case(browser, a.url, run_wav, ALL[:n], args.think_s,
                                                               a.workdir, b, args.quick, args.new_seed))
                for (name, b), runs in cases.items():
                    table.add(*cells(dur, n, name, "mannequin" if b is None else b.name, runs, args.quick))
                    print(table.last(), flush=True)
        browser.close()
    save_json(args.json, table)
    print(f"\nload average at the end {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
