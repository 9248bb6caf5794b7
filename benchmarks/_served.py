"""The web app of a checkout served in a process of its own, for benchmarks that compare two checkouts in one run.

    with served_app(Path("/work/main"), workdir) as app:          # `python -m app` of that checkout
        page.goto(app.url)

The server is that checkout's own `python -m app` (its `.venv` when it has one, else this interpreter with the
checkout first on the path), with the shipped checkpoints, its warm-up, and math threads as the app sets them. The
page needs the checkout's player bundle (`gesturelsm/webapp/player/dist/player.js`, built by `make setup`).
"""
from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from dataclasses import dataclass
from pathlib import Path


@dataclass
class App:
    name: str                 # how tables name it
    checkout: Path
    url: str
    workdir: Path             # the app's output folder (--workdir)
    pid: int


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def python_of(checkout: Path) -> str:
    venv = checkout / ".venv" / "bin" / "python"
    return str(venv) if venv.exists() else sys.executable


def check_checkout(checkout: Path) -> None:
    """One line for a folder that cannot be served: not a checkout, or its player bundle not built."""
    if not (checkout / "app" / "__main__.py").is_file():
        raise SystemExit(f"{checkout}: not a gesturelsm checkout (no app/__main__.py)")
    # the second: checkouts from before the player moved under the web package
    bundles = ("gesturelsm/webapp/player/dist/player.js", "app/player/dist/player.js")
    if not any((checkout / b).is_file() for b in bundles):
        raise SystemExit(f"{checkout}: its player bundle is not built (run `make setup` there)")


@contextlib.contextmanager
def served_app(checkout: Path, workdir: Path, name: str = "", max_seconds: float = 600, timeout_s: float = 900,
               extra: tuple[str, ...] = ()):
    """`python -m app` of `checkout` on a free port, until the block ends (then stopped as Ctrl-C stops it)."""
    checkout = Path(checkout).resolve()
    check_checkout(checkout)
    port = free_port()
    env = dict(os.environ, PYTHONPATH=str(checkout), GRADIO_ANALYTICS_ENABLED="False", HF_HUB_DISABLE_TELEMETRY="1")
    log = open(workdir.parent / f"server-{port}.log", "w")
    proc = subprocess.Popen([python_of(checkout), "-m", "app", "--port", str(port), "--workdir", str(workdir),
                             "--max-seconds", str(max_seconds), *extra], cwd=checkout, env=env, stdout=log,
                            stderr=subprocess.STDOUT)
    url = f"http://127.0.0.1:{port}/"
    try:
        t0 = time.perf_counter()
        while True:
            if proc.poll() is not None:
                raise SystemExit(f"the app of {checkout} stopped: see {log.name}")
            try:
                urllib.request.urlopen(url, timeout=5).read(1)
                break
            except OSError:
                if time.perf_counter() - t0 > timeout_s:
                    raise SystemExit(f"the app of {checkout} did not answer within {timeout_s:.0f} s") from None
                time.sleep(0.5)
        yield App(name or checkout.name, checkout, url, workdir, proc.pid)
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(60)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        log.close()
