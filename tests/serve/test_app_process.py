"""`python -m app` as a visitor's operator runs it (a subprocess on the tiny checkpoints): it says each start-up stage
as it begins (it said nothing for 18-45 s before its URL), and Ctrl-C or SIGTERM stops it with its own lines ("stopping
(SIGTERM): ...", "stopped"), exit 0, its outputs deleted, never Gradio's "Keyboard interruption in main thread"."""
from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class App:
    """`python -m app` in a subprocess; `lines` collects its stdout and stderr as they come."""

    def __init__(self, *args: str):
        env = {**os.environ, "PYTHONPATH": str(REPO), "PYTHONUNBUFFERED": "1"}
        self.proc = subprocess.Popen([sys.executable, "-m", "app", *args], cwd=REPO, env=env, text=True,
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
        self.lines: list[str] = []
        self._cond = threading.Condition()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            with self._cond:
                self.lines.append(line.rstrip("\n"))
                self._cond.notify_all()
        with self._cond:
            self._cond.notify_all()

    def wait_for(self, text: str, timeout: float = 300) -> None:
        with self._cond:
            if not self._cond.wait_for(lambda: any(text in ln for ln in self.lines) or self.proc.poll() is not None,
                                       timeout):
                raise AssertionError(f"no line with {text!r} in {timeout} s:\n" + "\n".join(self.lines))
        assert any(text in ln for ln in self.lines), "the app ended:\n" + "\n".join(self.lines)

    def stop(self, signum: int, timeout: float = 120) -> int:
        self.proc.send_signal(signum)
        code = self.proc.wait(timeout)
        self._reader.join(30)
        return code


@pytest.fixture
def app_args(tiny_assets, tmp_path):
    work = tmp_path / "work"
    return ["--checkpoints", str(tiny_assets), "--workdir", str(work), "--no-warmup", "--no-ahead",
            "--port", str(_free_port()), "--max-seconds", "20"], work


@pytest.mark.slow
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_the_app_says_each_start_up_stage_and_stops_cleanly(app_args, signum):
    args, work = app_args
    app = App(*args)
    try:
        app.wait_for("ready: methods")
    except BaseException:
        app.proc.kill()
        raise
    stages = [ln.split("] ", 1)[1] for ln in app.lines if ln.startswith("python -m app: [")]
    assert [s.split(" (")[0].split(" on ")[0].split(":")[0] for s in stages] == [
        "loading the models", "building the page", "starting the web server", "ready"]
    assert any(f"open http://127.0.0.1:{args[args.index('--port') + 1]}" in s for s in stages)
    (work / "req-0123").mkdir(parents=True, exist_ok=True)        # an output folder: deleted at the stop
    code = app.stop(signum)
    text = "\n".join(app.lines)
    what = "Ctrl-C" if signum == signal.SIGINT else "SIGTERM"
    assert code == 0, text
    assert f"stopping ({what}): closing the page and deleting its output files" in text
    assert app.lines[-1].endswith("] stopped"), text
    assert "Keyboard interruption" not in text and "Traceback" not in text
    assert not (work / "req-0123").exists()


@pytest.mark.slow
def test_a_stop_while_starting_is_one_line(app_args):
    args, _ = app_args
    app = App(*args)
    app.wait_for("loading the models")
    code = app.stop(signal.SIGTERM)
    text = "\n".join(app.lines)
    assert code == 0 and "Traceback" not in text and "Keyboard interruption" not in text, text
    assert app.lines[-1].endswith("] stopped") and any("stopping (SIGTERM)" in ln for ln in app.lines), text


@pytest.mark.slow
def test_stopping_the_app_with_replicas_prints_no_ray_noise(tiny_assets, tmp_path):
    """`python -m app --replicas 1` (a local Ray cluster) stopped by Ctrl-C, as a terminal sends it (to the whole
    process group): the app's own lines, no "(raylet) ... retried" warnings, no Ray process left."""
    pytest.importorskip("ray")
    args = ["--replicas", "1", "--cluster", "local", "--checkpoints", str(tiny_assets), "--workdir",
            str(tmp_path / "work"), "--no-warmup", "--no-ahead", "--port", str(_free_port()), "--max-seconds", "20"]
    env = {**os.environ, "PYTHONPATH": str(REPO), "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "app", *args], cwd=REPO, env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                            start_new_session=True)
    app = App.__new__(App)
    app.proc, app.lines, app._cond = proc, [], threading.Condition()
    app._reader = threading.Thread(target=app._read, daemon=True)
    app._reader.start()
    try:
        app.wait_for("ready: methods", timeout=900)
    except BaseException:
        os.killpg(proc.pid, signal.SIGKILL)
        raise
    os.killpg(proc.pid, signal.SIGINT)                                  # Ctrl-C in a terminal: the whole group
    code = proc.wait(300)
    app._reader.join(30)
    text = "\n".join(app.lines)
    assert code == 0, text
    assert "stopping the replicas" in text and app.lines[-1].endswith("] stopped"), text
    assert "(raylet)" not in text and "retried" not in text and "Traceback" not in text, text
    assert "Keyboard interruption" not in text and "Started Serve" not in text, text
