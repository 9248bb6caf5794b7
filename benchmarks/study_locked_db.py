"""The study server while another program holds its database's write lock: what each kind of request answers,
and how soon.

    .venv/bin/python benchmarks/study_locked_db.py [--hold 8] [--repo PATH] [--json FILE]

A study folder with tiny silent videos (as in study_load.py) is served by `gesturelsm study serve` in its own
process. Once a rater has opened the study, this process takes the SQLite write lock (BEGIN IMMEDIATE) and holds
it for --hold seconds; half a second in, four requests go out at once: the rater page, a Range request for a video,
a second rater opening the study, and the first rater's answer. Each row gives the status, whether the body is
JSON (what the page can show), and the time to the answer; the last row is the same answer sent again after the
lock is released. --repo serves the study from another checkout (e.g. a worktree of an older commit) to compare.
One run; the machine may be shared, so compare runs made at the same time.
"""
from __future__ import annotations

import argparse
import http.client
import json
import os
import socket
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _harness import Rows, Stopwatch, json_flag, save_json
from study_load import make_study


def request(port: int, method: str, path: str, body: dict | None = None, headers: dict | None = None) -> dict:
    conn = http.client.HTTPConnection("127.0.0.1", port, timeout=120)
    try:
        with Stopwatch() as clock:
            conn.request(method, path, json.dumps(body) if body is not None else None,
                         {**({"Content-Type": "application/json"} if body is not None else {}), **(headers or {})})
            r = conn.getresponse()
            raw = r.read()
        ms = clock.seconds * 1000
        try:
            data = json.loads(raw)
            is_json, message = True, data.get("error", "") if isinstance(data, dict) else ""
        except ValueError:
            is_json, message = False, raw[:60].decode("latin-1") if r.status >= 400 else ""
        return dict(status=r.status, json=is_json, ms=ms, message=message)
    finally:
        conn.close()


def serve(folder: Path, port: int, repo: str | None) -> subprocess.Popen:
    env = dict(os.environ, **({"PYTHONPATH": repo} if repo else {}))
    proc = subprocess.Popen([sys.executable, "-m", "gesturelsm", "study", "serve", str(folder), "--port", str(port)],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, cwd=repo or None)
    for _ in range(600):
        try:
            socket.create_connection(("127.0.0.1", port), 0.5).close()
            return proc
        except OSError:
            if proc.poll() is not None:
                raise SystemExit(proc.stderr.read().decode())
            time.sleep(0.1)
    raise SystemExit("the server did not start")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hold", type=float, default=8.0, help="seconds the write lock is held")
    ap.add_argument("--repo", help="serve from this checkout (PYTHONPATH) instead of the installed package")
    json_flag(ap)
    args = ap.parse_args()
    from gesturelsm.study.design import read_raters

    with tempfile.TemporaryDirectory(prefix="study-lock-") as tmp:
        folder = make_study(Path(tmp) / "study", 2, 2, 2)
        one, two = sorted(read_raters(folder).values(), key=lambda r: r.id)
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        server = serve(folder, port, args.repo)
        try:
            conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
            conn.request("POST", f"/api/{one.token}/open", "{}", {"Content-Type": "application/json"})
            session = json.loads(conn.getresponse().read())["session"]
            conn.close()
            calls = {
                "rater page (GET /r/<token>)": ("GET", f"/r/{one.token}", None, None),
                "video, Range (GET .../video/0/left)": ("GET", f"/api/{one.token}/video/0/left", None,
                                                        {"Range": "bytes=0-1023"}),
                "another rater opens (POST .../open)": ("POST", f"/api/{two.token}/open", {}, None),
                "answer (POST .../answer)": ("POST", f"/api/{one.token}/answer",
                                             dict(session=session, trial=0, choice="left", played=True), None),
            }
            holder = sqlite3.connect(folder / "responses.sqlite", isolation_level=None, timeout=30,
                                     check_same_thread=False)
            holder.execute("BEGIN IMMEDIATE")
            with Stopwatch() as lock:
                threading.Timer(args.hold, lambda: holder.execute("ROLLBACK")).start()
                time.sleep(0.5)
                results: dict[str, dict] = {}
                threads = [threading.Thread(target=lambda k=k, c=c: results.__setitem__(k, request(port, *c)))
                           for k, c in calls.items()]
                for t in threads:
                    t.start()
                for t in threads:
                    t.join()
                time.sleep(max(0.0, args.hold + 0.2 - lock.elapsed))
            holder.close()
            results["the same answer after the lock is released"] = request(port, *calls["answer (POST .../answer)"])
        finally:
            server.terminate()
            server.wait(30)
    print(f"write lock held by another program for {args.hold:g} s; requests sent 0.5 s into it"
          f"{' (served from ' + args.repo + ')' if args.repo else ''}; one run, the machine may be shared\n")
    table = Rows(["request", "status", "JSON body", "ms", "message"])
    for k, r in results.items():
        table.add(k, r["status"], "yes" if r["json"] else "no", f"{r['ms']:.0f}", r["message"][:70])
    print(table.markdown())
    save_json(args.json, table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
