"""The figures of docs/STUDY.md: a trial page (docs/study_trial.png) of a real study made by `gesturelsm batch`
from the shipped checkpoints and two of gesturelsm/webapp/examples' speech files, shot in headless Chromium; and the
results plot (docs/study_results.png) of that study answered by simulated raters (Bradley-Terry preferences with
strengths --strengths, a few raters answering at random), analysed by `gesturelsm study results`.

    .venv/bin/python scripts/study_figures.py [--work /tmp/study-figures] [--raters 24]
"""
from __future__ import annotations

import argparse
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
CHROMIUM = "/usr/lib/chromium/chromium"


def simulate(folder: Path, strengths: dict[str, float], careless: int, seed: int = 0) -> None:
    """Every rater answers every trial through the database API as the server would record it."""
    from gesturelsm.study import db
    from gesturelsm.study.design import read_conditions, read_raters

    genuine = {v: m for v, (_, m) in read_conditions(folder).genuine.items()}
    engine = db.open_db(db.default_url(folder))
    rng = np.random.default_rng(seed)
    raters = sorted(read_raters(folder).values(), key=lambda r: r.id)
    for rater in raters[1:]:                      # rater 1 is left unanswered for the screenshot
        bad = rater.id > len(raters) - careless
        st = db.open_session(engine, rater.id, 0)
        for t in rater.trials:
            if bad:
                choice = str(rng.choice(["left", "right", "none"]))
            elif t.check == "mismatch":
                choice = t.expect
            else:
                d = strengths[genuine[t.left]] - strengths[genuine[t.right]]
                choice = "left" if rng.random() < 1 / (1 + np.exp(-d)) else "right"
            nxt = t.index + 1 if t.index + 1 < len(rater.trials) else None
            db.record(engine, rater.id, st.session, t.index, choice=choice, ratings=None, played=True,
                      next_trial=nxt, n_trials=len(rater.trials))


def screenshot(folder: Path, out: Path) -> None:
    from playwright.sync_api import sync_playwright

    from app.screenshot import CHROMIUM_ARGS
    from gesturelsm.study.design import read_raters

    token = next(r.token for r in read_raters(folder).values() if r.id == 1)
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = subprocess.Popen([sys.executable, "-c", "import sys; from gesturelsm.study.server import serve; "
                               f"serve(sys.argv[1], port={port})", str(folder)], cwd=REPO)
    try:
        time.sleep(8)
        with sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=CHROMIUM, args=list(CHROMIUM_ARGS))
            page = browser.new_page(viewport={"width": 820, "height": 640})
            page.goto(f"http://127.0.0.1:{port}/r/{token}")
            page.wait_for_selector('#trial[data-trial="0"]', timeout=60000)
            page.evaluate("""() => Promise.all([...document.querySelectorAll('video')].map(v => new Promise(ok => {
                v.pause(); v.currentTime = 1.2; v.addEventListener('seeked', ok, {once: true}); })))""")
            page.wait_for_timeout(500)
            page.screenshot(path=str(out))
            browser.close()
    finally:
        server.terminate()
        server.wait(30)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--work", default="/tmp/study-figures")
    ap.add_argument("--raters", type=int, default=24)
    ap.add_argument("--careless", type=int, default=3, help="raters answering at random (the checks drop them)")
    ap.add_argument("--reuse", action="store_true", help="keep an answered study in --work; redo only the figures")
    ap.add_argument("--strengths", default="gesturelsm=0.9,rectified_flow=0.5,ddim=0",
                    help="simulated Bradley-Terry log-strengths")
    args = ap.parse_args()
    from gesturelsm.cli import main as cli

    work = Path(args.work)
    study = work / "study"
    if not (args.reuse and (study / "responses.sqlite").exists()):
        shutil.rmtree(work, ignore_errors=True)
        (work / "speech").mkdir(parents=True)
        for name in ("hello", "weekend", "pipeline"):
            shutil.copy(REPO / "gesturelsm" / "webapp" / "examples" / f"{name}.wav", work / "speech")
        assert cli(["batch", "--audio-dir", str(work / "speech"), "--out", str(study), "--raters", str(args.raters),
                    "--methods", "gesturelsm", "rectified_flow", "ddim", "--size", "256", "--attention", "0.25"]) == 0
        strengths = {k: float(v) for k, v in (kv.split("=") for kv in args.strengths.split(","))}
        simulate(study, strengths, args.careless)
    assert cli(["study", "results", str(study)]) == 0
    shutil.copy(study / "results" / "results.png", REPO / "docs" / "study_results.png")
    screenshot(study, REPO / "docs" / "study_trial.png")
    for p in ("study_trial.png", "study_results.png"):
        print(p, (REPO / "docs" / p).stat().st_size // 1024, "KiB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
