"""Load on the study server: N raters answering at once over loopback against SQLite (the default database).

    .venv/bin/python benchmarks/study_load.py [--raters 50] [--speeches 4] [--methods 3] [--timeout 300]
                                              [--json FILE]

A study folder with tiny silent videos (key, design, N links, as `gesturelsm batch` writes them) is made in a
temporary folder and served by `gesturelsm.study.server.serve` in its own process (uvicorn). Every rater is a
thread with its own keep-alive connection: it opens its page's state, then for every trial fetches the first
KiB of both videos (a Range request, as <video> does), posts its answer (timed) and replays the same answer
(must be refused with 409). At the end the database must hold every (rater, trial) exactly once.
Prints p50 / p95 / max answer latency (the replays are left out) and answers per second. The run is bounded by
--timeout; the machine may be shared with other jobs, so compare runs made at the same time.
"""
from __future__ import annotations

import argparse
import csv
import http.client
import json
import socket
import subprocess
import sys
import tempfile
import threading
import time
from itertools import product
from pathlib import Path

import numpy as np
from _harness import Rows, Stopwatch, json_flag, save_json


def make_study(root: Path, speeches: int, methods: int, raters: int) -> Path:
    import imageio

    from gesturelsm.study.design import Design, invite, write_design

    (root / "videos").mkdir(parents=True)
    (root / "key").mkdir()
    frame = np.full((64, 64, 3), 128, np.uint8)
    rows = []
    for s, m in product(range(speeches), range(methods)):
        name = f"v_{s:02d}{m:02d}{'0' * 6}.mp4"
        with imageio.get_writer(root / "videos" / name, fps=10, codec="libx264", pixelformat="yuv420p") as w:
            for _ in range(5):
                w.append_data(frame)
        rows.append((name, f"speech{s}.wav", f"method{m}"))
    with open(root / "key" / "conditions.csv", "w", newline="") as fh:
        csv.writer(fh).writerows([("video", "audio", "method"), *rows])
    write_design(root, Design("pairwise", 0.15, 0))
    invite(root, raters)
    return root


def rater_run(port: int, token: str, lat: list[float], errors: list[str], counts: dict) -> None:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)

    def post(path: str, body: dict) -> tuple[int, dict]:
        conn.request("POST", f"/api/{token}/{path}", json.dumps(body), {"Content-Type": "application/json"})
        r = conn.getresponse()
        return r.status, json.loads(r.read())

    try:
        status, st = post("open", {})
        session = st["session"]
        while st.get("trial"):
            i = st["trial"]["index"]
            for side in ("left", "right"):
                conn.request("GET", f"/api/{token}/video/{i}/{side}", headers={"Range": "bytes=0-1023"})
                r = conn.getresponse()
                r.read()
                if r.status != 206:
                    errors.append(f"video {i} {side}: {r.status}")
            body = dict(session=session, trial=i, choice="left", played=True)
            with Stopwatch() as clock:
                status, nxt = post("answer", body)
            lat.append(clock.seconds)
            if status != 200:
                errors.append(f"answer {i}: {status} {nxt}")
                return
            status, _ = post("answer", body)                 # a replay: refused, counted once
            counts["replays_refused"] += status == 409
            st = nxt
        counts["completed"] += bool(st.get("code"))
    except Exception as exc:                                  # reported in the table
        errors.append(f"{type(exc).__name__}: {exc}")
    finally:
        conn.close()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--raters", type=int, default=50)
    ap.add_argument("--speeches", type=int, default=4)
    ap.add_argument("--methods", type=int, default=3)
    ap.add_argument("--timeout", type=float, default=300)
    json_flag(ap)
    args = ap.parse_args()
    from gesturelsm.study import db
    from gesturelsm.study.design import read_raters

    with tempfile.TemporaryDirectory(prefix="study-load-") as tmp:
        folder = make_study(Path(tmp) / "study", args.speeches, args.methods, args.raters)
        raters = list(read_raters(folder).values())
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        server = subprocess.Popen([sys.executable, "-c", "import sys; from gesturelsm.study.server import serve; "
                                   f"serve(sys.argv[1], port={port}, log=lambda *_: None)", str(folder)])
        try:
            for _ in range(600):
                try:
                    socket.create_connection(("127.0.0.1", port), 0.5).close()
                    break
                except OSError:
                    time.sleep(0.1)
            lat: list[float] = []
            errors: list[str] = []
            counts = dict(completed=0, replays_refused=0)
            threads = [threading.Thread(target=rater_run, args=(port, r.token, lat, errors, counts), daemon=True)
                       for r in raters]
            with Stopwatch() as clock:
                for t in threads:
                    t.start()
                for t in threads:
                    t.join(max(0.0, args.timeout - clock.elapsed))
            wall = clock.seconds
            hung = sum(t.is_alive() for t in threads)
        finally:
            server.terminate()
            server.wait(30)
        rows = db.all_answers(db.open_db(db.default_url(folder)))
        want = {(r.id, t.index) for r in raters for t in r.trials}
        got = [(r["rater"], r["trial"]) for r in rows]
        lost, doubled = len(want - set(got)), len(got) - len(set(got))
    ms = np.array(lat) * 1000
    print(f"{args.raters} raters at once, {len(want) // args.raters} trials each, SQLite, loopback "
          f"(one run; the machine may be shared)\n")
    table = Rows(["answers", "wall s", "answers/s", "p50 ms", "p95 ms", "max ms", "lost", "doubled", "replays refused",
                  "completed", "errors", "hung"])
    table.add(len(lat), f"{wall:.1f}", f"{len(lat) / wall:.0f}", f"{np.percentile(ms, 50):.1f}",
              f"{np.percentile(ms, 95):.1f}", f"{ms.max():.1f}", lost, doubled, counts["replays_refused"],
              f"{counts['completed']} / {args.raters}", len(errors), hung)
    print(table.markdown())
    save_json(args.json, table)
    for e in errors[:5]:
        print("error:", e)
    return 0 if not (lost or doubled or errors or hung) else 1


if __name__ == "__main__":
    sys.exit(main())
