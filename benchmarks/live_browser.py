"""The Live tab end to end: real headless Chromium, its fake microphone fed real speech, for N seconds.

    .venv/bin/python benchmarks/live_browser.py                        # 30 s of the real take (../shared)
    .venv/bin/python benchmarks/live_browser.py --seconds 60 --wav speech.wav --screenshot docs/live.png
    .venv/bin/python benchmarks/live_browser.py --character avatar.vrm      # on a character (Character upload)

The app is served in this process with the shipped checkpoints (as `python -m app`); Chromium opens it with
`--use-fake-device-for-media-stream --use-file-for-fake-audio-capture=<wav>` (the wav cut to --seconds, 48 kHz
16-bit; Chromium loops it), presses Record on the Live tab, waits --seconds and presses Stop (with --character, the file
is chosen in the page's Character upload first, so the stream is on it). Reported:

* the page's meter at the end (#live-latency = median, #live-stats = p90 and real-time factor): from a microphone
  chunk's arrival at the server to the motion covering it being ready, since the stream started;
* the speech-to-screen latency the live player measures in the browser (data-shown-median-ms / -p90-ms): for each
  drawn frame, when it was drawn - (when recording started + frame / 30 fps);
* frames received by the browser vs audio seconds streamed, frames drawn, draws per second (sampled each second),
  chunks that arrived out of order (gaps);
* CPU share (CPU seconds / wall seconds; 1.0 = one core) of the server process and of the browser processes;
* the machine's load average before and after (the 2 cores are shared: compare numbers within one run).
"""
from __future__ import annotations

from _harness import BEAT2, set_threads

import argparse
import dataclasses
import os
import re
import resource
import statistics
import sys
import threading
import time
from pathlib import Path

os.environ["GRADIO_ANALYTICS_ENABLED"] = "False"
os.environ["HF_HUB_DISABLE_TELEMETRY"] = "1"

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
TAKE = BEAT2 / "wave16k" / "2_scott_0_1_1.wav"
FAKE_MIC = ["--use-fake-ui-for-media-stream", "--use-fake-device-for-media-stream"]
PAGE_STATE = """() => { const e = document.querySelector('#live-player'), live = window.gesturelsmPlayer.live,
    v = (id) => document.querySelector(`#${id}`).textContent;
  return {frames: Number(e.dataset.frames), fps: Number(e.dataset.fps || 0), state: e.dataset.state,
          received: live.player.frames(), gaps: Number(e.dataset.gaps || 0),
          shown_median: Number(e.dataset.shownMedianMs || NaN), shown_p90: Number(e.dataset.shownP90Ms || NaN),
          latency: v('live-latency'), stats: v('live-stats'), status: v('live-status'),
          // seconds of speech: spoken (since recording started), at the server, motion in the browser, on screen
          spoken: (performance.now() - live.spoken0) / 1000,
          server_audio: (live.last || {}).audio_seconds || 0,
          server_audio_age: (performance.now() - ((live.last || {}).at || 0)) / 1000,
          on_screen: Number(e.dataset.frame) / 30}; }"""


def mic_wav(src: Path, seconds: float, start_s: float, out: Path) -> Path:
    """`seconds` of `src` from `start_s`, as the 48 kHz 16-bit mono wav Chromium's fake device reads."""
    import soundfile as sf

    from gesturelsm.audio import resample, to_mono

    y, sr = sf.read(src, dtype="float32")
    y = to_mono(y)[int(start_s * sr):int((start_s + seconds) * sr)]
    if len(y) < seconds * sr * 0.9:
        raise SystemExit(f"{src} has less than {seconds:g} s of audio after {start_s:g} s")
    sf.write(out, np.clip(resample(y, sr, 48000), -1, 1), 48000, subtype="PCM_16")
    return out


def child_cpu_s(root: int) -> float:
    """CPU seconds (user + system) of all live descendants of process `root` (the browser and its helpers)."""
    kids: dict[int, list[int]] = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                ppid = int(open(f"/proc/{d}/stat").read().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            kids.setdefault(ppid, []).append(int(d))
    total, todo, tick = 0.0, list(kids.get(root, [])), os.sysconf("SC_CLK_TCK")
    while todo:
        pid = todo.pop()
        todo += kids.get(pid, [])
        try:
            f = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
            total += (int(f[11]) + int(f[12])) / tick
        except (OSError, IndexError, ValueError):
            pass
    return total


def self_cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def run(args) -> dict:
    from playwright.sync_api import sync_playwright

    from app.screenshot import CHROMIUM_ARGS
    from gesturelsm.webapp.ui import serve_locally
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.service import GestureService

    set_threads(1)
    work = Path(args.workdir)
    work.mkdir(parents=True, exist_ok=True)
    wav = mic_wav(Path(args.wav), args.seconds, args.start, work / "mic48k.wav")
    service = GestureService.from_settings(ServiceSettings(workdir=str(work / "app")))
    service.warmup()
    demo, url = serve_locally(service)
    over = {k: v for k in ("commit", "lookahead", "held", "steps", "cfg") if (v := getattr(args, k)) is not None}
    if over:                                            # compare live settings (the app's defaults otherwise)
        demo.live_manager.config = dataclasses.replace(demo.live_manager.config, **over)
    config = demo.live_manager.config
    samples, load0 = [], os.getloadavg()
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=args.chromium,
                                         args=CHROMIUM_ARGS + FAKE_MIC + [f"--use-file-for-fake-audio-capture={wav}"])
            page = browser.new_page(viewport={"width": 1400, "height": 1300})
            page.goto(f"{url}?measure=1")              # the live feed stamps each message's arrival (last.at)
            page.wait_for_selector("#live-player[data-ready]", timeout=60000)
            page.wait_for_function("() => window.gesturelsmPlayer && window.gesturelsmPlayer.live", timeout=60000)
            if args.character:                          # chosen as a visitor does; the stream then uses it
                page.locator("#character input[type=file]").set_input_files(args.character)
                page.locator("#character", has_text="humanoid bones").wait_for(timeout=120000)
                page.wait_for_function("() => window.gesturelsmPlayer.live.chosen !== null", timeout=60000)
            page.locator("#live-player").scroll_into_view_if_needed()
            cpu0, bcpu0, t0 = self_cpu_s(), child_cpu_s(os.getpid()), time.perf_counter()
            page.locator("#live-record").click()
            while time.perf_counter() - t0 < args.seconds:
                time.sleep(1.0)
                samples.append(page.evaluate(PAGE_STATE))
            end = page.evaluate(PAGE_STATE)
            end["body"] = page.get_attribute("#live-player", "data-character") or "mannequin"
            wall = time.perf_counter() - t0
            cpu, bcpu = self_cpu_s() - cpu0, child_cpu_s(os.getpid()) - bcpu0
            if args.screenshot:
                page.locator("#live-player-box").locator("xpath=ancestor::div[contains(@class,'tabitem')][1]") \
                    .screenshot(path=args.screenshot)
            page.locator("#live-stop").click()
            page.wait_for_function("() => document.querySelector('#live-status').textContent === 'stopped'",
                                   timeout=60000)
            browser.close()
        time.sleep(1.0)
        left = sum(t.name == "gesturelsm-live" and t.is_alive() for t in threading.enumerate())
    finally:
        demo.close()
    return {"config": config, "end": end, "samples": samples, "wall": wall, "cpu": cpu, "bcpu": bcpu,
            "load": (load0, os.getloadavg()),
            "left": left}


def report(r: dict, seconds: float) -> None:
    e = r["end"]
    med = e["latency"]
    m = re.search(r"p90 (\d+) ms · real-time factor ([\d.]+)x", e["stats"])
    p90, rtf = (m.group(1), m.group(2)) if m else ("-", "-")
    fps = [s["fps"] for s in r["samples"] if s["state"] == "playing"]
    rows = [
        ("speech streamed (s)", f"{seconds:g} (recording {r['wall']:.1f} s wall)"),
        ("body in the live player (data-character)", e["body"]),
        ("live settings: commit / look-ahead / held (latents), steps, CFG",
         f"{r['config'].commit} / {r['config'].lookahead} / {r['config'].held}, {r['config'].steps}, "
         f"{r['config'].cfg:g}"),
        ("server latency median (ms), #live-latency", med or "-"),
        ("server latency p90 (ms), #live-stats", p90),
        ("real-time factor (audio s / compute s)", rtf),
        ("speech-to-screen median (ms), browser", f"{e['shown_median']:.0f}"),
        ("speech-to-screen p90 (ms), browser", f"{e['shown_p90']:.0f}"),
        ("motion frames received by the browser", f"{e['received']} ({e['received'] / 30:.1f} s)"),
        ("frames drawn (data-frames)", str(e["frames"])),
        ("draws per second, median of 1-s samples", f"{statistics.median(fps):.0f}" if fps else "-"),
        ("chunks out of order (gaps)", str(e["gaps"])),
        ("at the end, s behind the speech: audio at the server",
         f"{e['spoken'] - e['server_audio'] - e['server_audio_age']:.2f}"),
        ("at the end, s behind the speech: motion in the browser", f"{e['spoken'] - e['received'] / 30:.2f}"),
        ("at the end, s behind the speech: motion on screen", f"{e['spoken'] - e['on_screen']:.2f}"),
        ("CPU share, server process (cores)", f"{r['cpu'] / r['wall']:.2f}"),
        ("CPU share, browser processes (cores)", f"{r['bcpu'] / r['wall']:.2f}"),
        ("live workers left after Stop", str(r["left"])),
        ("load average before / after (1 min)", f"{r['load'][0][0]:.1f} / {r['load'][1][0]:.1f}"),
    ]
    w = max(len(k) for k, _ in rows)
    print(f"| {'Live tab, real Chromium, fake microphone'.ljust(w)} | value |\n|{'-' * (w + 2)}|-------|")
    for k, v in rows:
        print(f"| {k.ljust(w)} | {v} |")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seconds", type=float, default=30.0, help="how long to speak into the fake microphone")
    p.add_argument("--wav", default=str(TAKE), help="speech file (default: the real BEAT2 take in ../shared)")
    p.add_argument("--start", type=float, default=5.0, help="second of the wav to start from")
    p.add_argument("--chromium", default="/usr/lib/chromium/chromium")
    p.add_argument("--workdir", default="/tmp/gesturelsm-live-browser")
    p.add_argument("--screenshot", help="also save a PNG of the Live tab while it streams")
    p.add_argument("--character", help="choose this .vrm / .glb / .gltf in the page first (the stream is on it)")
    for k, t in (("commit", int), ("lookahead", int), ("held", int), ("steps", int), ("cfg", float)):
        p.add_argument(f"--{k}", type=t, help=f"live {k} (default: the app's, gesturelsm/live/stream.py LiveConfig)")
    args = p.parse_args(argv)
    if not Path(args.wav).exists():
        print(f"speech file not found: {args.wav} (give --wav, or put ../shared beside the repo)", file=sys.stderr)
        return 2
    report(run(args), args.seconds)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
