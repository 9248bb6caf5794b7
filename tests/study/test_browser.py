"""A small pairwise study run end to end in headless Chromium: three raters answer through the page (the third
fails the attention checks), the server is stopped and started again halfway, a reload resumes; then
`gesturelsm study results` drops the third rater and ranks the methods as the raters preferred, and the database
holds every answer exactly once."""
from __future__ import annotations

import contextlib
import json
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

from _study_support import make_synthetic_study
from _support import CHROMIUM, free_port

REPO = Path(__file__).resolve().parents[2]
PREFERRED = ["alpha", "beta", "gamma"]          # what the attentive raters prefer, best first


@contextlib.contextmanager
def _server(argv: list[str], port: int):
    proc = subprocess.Popen(argv, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        for _ in range(1200):
            try:
                urllib.request.urlopen(f"http://127.0.0.1:{port}/r/x", timeout=1)
            except urllib.error.HTTPError:               # 404 for the unknown token: it is up
                break
            except OSError:
                if proc.poll() is not None:
                    raise AssertionError(proc.stderr.read().decode()) from None
                time.sleep(0.1)
        yield f"http://127.0.0.1:{port}"
    finally:
        proc.terminate()
        proc.wait(30)


def _choice(trial: dict, genuine: dict, attentive: bool) -> str:
    """An attentive rater picks the genuine video in a mismatch check and the preferred method otherwise; the
    inattentive one picks the opposite side every time."""
    if trial["check"] == "mismatch":
        side = trial["expect"]
    else:
        left, right = genuine[trial["left"]], genuine[trial["right"]]
        side = "left" if PREFERRED.index(left) < PREFERRED.index(right) else "right"
    return side if attentive else {"left": "right", "right": "left"}[side]


def _answer(page, trial: dict, genuine: dict, attentive: bool) -> None:
    page.wait_for_selector(f'#trial[data-trial="{trial["index"]}"][data-kind="pair"]', timeout=20000)
    page.evaluate("() => document.querySelectorAll('video').forEach(v => { v.defaultPlaybackRate = 4; "
                  "v.playbackRate = 4; })")
    page.wait_for_selector("#prefer-none:enabled", timeout=20000)
    page.click(f"#prefer-{_choice(trial, genuine, attentive)}")


@pytest.mark.browser
def test_pairwise_study_in_the_browser_with_a_restart(tmp_path):
    if CHROMIUM is None:
        pytest.skip("chromium is not installed (apt-get install chromium libatomic1; scripts/setup.sh does it)")
    from playwright.sync_api import sync_playwright

    from app.screenshot import CHROMIUM_ARGS
    from gesturelsm.cli import main
    from gesturelsm.study import db
    from gesturelsm.study.design import read_conditions, read_raters

    folder = make_synthetic_study(tmp_path / "study", methods=PREFERRED, raters=3, attention=0.4)
    raters = {r.id: r for r in read_raters(folder).values()}
    genuine = {v: m for v, (_, m) in read_conditions(folder).genuine.items()}
    trials = {i: [dict(t.__dict__) for t in raters[i].trials] for i in raters}
    n = len(trials[1])
    assert {t["check"] for t in trials[1]} == {"", "mismatch", "repeat"}
    port = free_port()
    cli = [sys.executable, "-m", "gesturelsm", "study", "serve", str(folder), "--port", str(port)]
    direct = [sys.executable, "-c", "import sys; from gesturelsm.study.server import serve; "
              f"serve(sys.argv[1], port={port})", str(folder)]
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=list(CHROMIUM_ARGS))
        try:
            page = browser.new_page()
            with _server(cli, port) as url:
                page.goto(f"{url}/r/{raters[1].token}")
                page.wait_for_selector('#trial[data-trial="0"]', timeout=20000)
                assert page.is_disabled("#prefer-left")            # locked until both videos have played
                for t in trials[1]:
                    _answer(page, t, genuine, True)
                page.wait_for_selector("#done:not(:empty)", timeout=20000)
                assert page.text_content("#progress") == f"{n} / {n}"
                code1 = page.text_content("#done")
                page.goto(f"{url}/r/{raters[2].token}")
                for t in trials[2][: n // 2]:
                    _answer(page, t, genuine, True)
                page.wait_for_selector(f'#progress:text-is("{n // 2} / {n}")', timeout=20000)
            with _server(direct, port) as url:                     # restarted: the reload resumes at trial n/2
                page.reload()
                page.wait_for_selector(f'#progress:text-is("{n // 2} / {n}")', timeout=20000)
                other = browser.new_page()                         # a stale tab of rater 2 is refused
                other.goto(f"{url}/r/{raters[2].token}")
                other.wait_for_selector(f'#trial[data-trial="{n // 2}"]', timeout=20000)
                page.wait_for_selector("#prefer-none:enabled", timeout=20000)
                page.click("#prefer-left")                         # the first tab answers after `other` took over
                page.wait_for_selector("#error:not(:empty)", timeout=20000)
                assert "another tab" in page.text_content("#error")
                page.reload()                                      # taking it back: nothing was recorded
                for t in trials[2][n // 2:]:
                    _answer(page, t, genuine, True)
                page.wait_for_selector("#done:not(:empty)", timeout=20000)
                other.close()
                page.goto(f"{url}/r/{raters[3].token}")
                for t in trials[3]:
                    _answer(page, t, genuine, False)
                page.wait_for_selector("#done:not(:empty)", timeout=20000)
                page.goto(f"{url}/r/{raters[1].token}")             # a finished rater sees the code again
                page.wait_for_selector("#done:not(:empty)", timeout=20000)
                assert page.text_content("#done") == code1
        finally:
            browser.close()

    rows = db.all_answers(db.open_db(db.default_url(folder)))
    assert sorted((r["rater"], r["trial"]) for r in rows) == [(i, k) for i in (1, 2, 3) for k in range(n)]
    assert all(r["played"] for r in rows)
    assert main(["study", "results", str(folder), "--bootstrap", "200"]) == 0
    summary = json.loads((folder / "results" / "summary.json").read_text())
    assert summary["kept"] == [1, 2] and summary["ranking"] == PREFERRED
    assert (folder / "results" / "results.png").stat().st_size > 1000
    assert "rater 3 dropped" in (folder / "results" / "results.md").read_text()
