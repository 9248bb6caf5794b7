"""What an edit costs against regenerating the take: a 2 s range of a 60 s take, per method that can edit.

    .venv/bin/python benchmarks/edit_speed.py [--checkpoints DIR ...] [--threads 2] [--rounds 5] [--seconds 60]
    .venv/bin/python benchmarks/edit_speed.py --page [--rounds 5]        # the page, in headless Chromium

For every loaded method whose sampler can hold known latents (its spec's `inpainting`), on one prepared speech (speech
features are computed once and counted in neither): `generate` of the whole take at the method's default steps,
against `edit` of the upper body and hands over 2 s in its middle (encoding the take, sampling the windows that
range touches, decoding around it, merging). Rounds alternate generate and edit, so load from other processes hits
both alike; medians of wall time, and their ratio. Speech: the real BEAT2 take 2_scott_0_2_2 (from ../shared) cut
to --seconds when present, else synthetic speech. The authors' GestureLSM is measured when --checkpoints includes
its converted weights (`gesturelsm import-reference`).

--page: the page's Edit section on the shipped models in headless Chromium (Debian's, as the browser tests): Generate
10 s of speech with GestureLSM alone, then per round a new seed, upper + hands over 2-4 s and a click on
#edit-run, timed until the player shows the edited motion (its payload replaced and the A/B toggle on the edit);
medians over the rounds.
"""
from __future__ import annotations

from _harness import BEAT2, cpu_name, set_threads
from _harness import timed as harness_timed

import argparse
import statistics
import sys
import time
from pathlib import Path

import torch

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))
WAV = BEAT2 / "wave16k" / "2_scott_0_2_2.wav"
EDIT_SECONDS = 2.0



def load_speech(seconds: float):
    import numpy as np

    if WAV.exists():
        from gesturelsm.audio import load_audio

        y = load_audio(WAV)
        return y[:int(seconds * 16000)], "BEAT2 2_scott_0_2_2"
    from _support import speech_like

    return speech_like(seconds).astype(np.float32), "synthetic"


def timed(fn) -> float:
    return harness_timed(fn, 1).median


def measure(pipe, speech, method: str, rounds: int) -> dict:
    """Median seconds of generating the take and of editing 2 s of it, and how many windows each samples."""
    from gesturelsm.flows import sampled_windows, window_layout
    from gesturelsm.motion.editing import edit_spec

    steps = pipe.spec(method).default_steps
    motion = pipe.generate(speech, steps=steps, method=method, output="raw").motion
    mid = speech.duration / 2
    ask = {"upper": [(mid - EDIT_SECONDS / 2, mid + EDIT_SECONDS / 2)], "hands": [(mid - EDIT_SECONDS / 2,
                                                                                  mid + EDIT_SECONDS / 2)]}
    pipe.edit(motion, speech, ask, method=method, steps=steps)                  # warm: traces, caches
    gen, edit = [], []
    for _ in range(rounds):
        gen.append(timed(lambda: pipe.generate(speech, steps=steps, method=method, seed=1, output="raw")))
        edit.append(timed(lambda: pipe.edit(motion, speech, ask, method=method, steps=steps, seed=1)))
    L = -(-motion.num_frames // 4)
    t, s = 32, 4
    spec = edit_spec(ask, motion.num_frames)
    free = torch.from_numpy(spec.free_latents("upper", L) | spec.free_latents("hands", L))
    from gesturelsm.flows import Held

    held = Held(torch.zeros(1, L, 1), ~free[None, :, None])
    return {"steps": steps, "generate": statistics.median(gen), "edit": statistics.median(edit),
            "windows": (len(sampled_windows(L, t, s, held)), len(window_layout(L, t, s)))}


PAGE_SHOWN_JS = """(old) => { const p = window.gesturelsmPlayer;
    return p.payload && p.payload.id !== old && p.element.dataset.ab === 'edited'; }"""


def measure_page(rounds: int) -> list[float]:
    """Seconds from a click on #edit-run to the edited motion in the player, per round (see the docstring)."""
    import tempfile

    import soundfile as sf

    from _support import player_page, served, shipped_service

    work = Path(tempfile.mkdtemp(prefix="edit-page-"))
    audio, _ = load_speech(10.0)
    sf.write(work / "speech.wav", audio, 16000)
    times = []
    with served(shipped_service(work / "service")) as url, player_page(url, "#motion-player") as page:
        for label in ("DDIM", "Rectified flow"):
            page.locator("#methods label", has_text=label).click()
        page.locator("#auto-transcribe input[type=checkbox]").uncheck()
        page.locator("#speech input[type=file]").first.set_input_files(str(work / "speech.wav"))
        page.locator("#speech [data-testid=download-link]").wait_for(state="attached", timeout=30000)
        page.locator("#generate").click()
        page.locator("#edit-run").wait_for(state="visible", timeout=180000)
        for box, value in (("#edit-start input", "2"), ("#edit-end input", "4")):
            page.locator(box).fill(value)
            page.locator(box).press("Enter")
        for r in range(rounds):
            page.locator("#edit-seed input").fill(str(r + 2))
            page.locator("#edit-seed input").press("Enter")
            old = page.evaluate("() => window.gesturelsmPlayer.payload.id")
            t0 = time.perf_counter()
            page.locator("#edit-run").click()
            page.wait_for_function(PAGE_SHOWN_JS, arg=old, timeout=120000)
            times.append(time.perf_counter() - t0)
    return times


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--checkpoints", nargs="+", default=None, help="checkpoint folders/files (default: shipped)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--methods", nargs="+", default=None, help="only these (default: every method that can edit)")
    ap.add_argument("--page", action="store_true", help="time the page's edit in headless Chromium instead")
    args = ap.parse_args()
    set_threads(args.threads)
    if args.page:
        t = measure_page(args.rounds)
        print(f"the page, 10 s of speech, GestureLSM, upper + hands over 2-4 s; {cpu_name()}; {len(t)} rounds\n")
        print("| click on #edit-run -> edited motion in the player (s) | median | min | max |\n|---|---|---|---|")
        print(f"| {', '.join(f'{x:.2f}' for x in t)} | {statistics.median(t):.2f} | {min(t):.2f} | {max(t):.2f} |")
        return
    from gesturelsm.constants import ASSETS
    from gesturelsm.pipeline import GesturePipeline

    pipe = GesturePipeline.from_pretrained(checkpoints=args.checkpoints or [ASSETS], methods=args.methods)
    audio, source = load_speech(args.seconds)
    speech = pipe.prepare_speech(audio, 16000, transcribe=False)
    rows = []
    for method in (m for m in pipe.methods if pipe.spec(m).inpainting):
        r = measure(pipe, speech, method, args.rounds)
        rows.append(f"| {method} | {r['steps']} | {r['generate']:.2f} | {r['edit']:.2f} | "
                    f"{r['generate'] / r['edit']:.1f}x | {r['windows'][0]} of {r['windows'][1]} |")
        print(f"{method}: done", file=sys.stderr, flush=True)
    print(f"{speech.duration:.0f} s of speech ({source}); edit: upper + hands over {EDIT_SECONDS:g} s in the middle; "
          f"{cpu_name()}, {args.threads} threads; medians of {args.rounds} alternating rounds\n")
    print("| method | steps | regenerate the take (s) | edit 2 s of it (s) | edit is faster by | windows sampled |")
    print("|---|---|---|---|---|---|")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
