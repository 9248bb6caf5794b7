"""Render the page's mp4 in its own low-priority process, so that generation, live streams and a browser on the same
machine come first.

Why a process, not a niced thread: Linux's autogroup scheduling (on by default:
/proc/sys/kernel/sched_autogroup_enabled) first shares the CPU fairly between sessions (a terminal, a desktop app, a
browser launched detached) and applies a thread's niceness only inside its session. A browser playing the page on the
same machine is a session of its own, so a render thread niced inside the server would still take the server's whole
share of the CPU from it (docs/WEBAPP.md has the frame rates). So the render runs as `python -m
gesturelsm.render.background --nice N render ...` (the `gesturelsm render` command) in a new session, i.e. its own
autogroup, which lowers its autogroup's and its own priority before it renders; its GL threads and ffmpeg inherit both.
Where autogroups do not exist (other kernels, other systems) the process is still niced.

    render_apart([seq_a, seq_b], audio_16k, "out/gestures.mp4", labels=["A", "B"], size=(384, 384),
                 body_path=body.path, gen_seconds=[0.4, None], progress=cb, nice=19)

The motions go to the process as BEAT2 npz files (MotionSequence.save, exact float32) and the speech as a float WAV
(exact samples) in a folder beside `out`, removed afterwards; progress comes back as JSON lines
(`gesturelsm render --progress-json`), the renderer's notes as RenderWarning, and a failure as RenderError with the
renderer's own message.
"""
from __future__ import annotations

import atexit
import json
import logging
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import warnings
from pathlib import Path
from typing import Sequence

import numpy as np

from ..constants import Progress
from ..errors import Cancellable, CancelToken, Cancelled, RenderError
from ..motion.sequence import MotionSequence
from .frames import RenderWarning

log = logging.getLogger(__name__)
AUTOGROUP = Path("/proc/self/autogroup")
_running: set[subprocess.Popen] = set()
CANCEL_POLL_S = 0.1          # how often a running render asks whether it was cancelled
_lock = threading.Lock()


# render_apart's `cancelled` said yes: the render process was stopped and its partial file removed
RenderCancelled = Cancelled


def lower_this_process(nice: int) -> dict:
    """Add `nice` to this process's niceness and set its autogroup's niceness to `nice` (Linux; call it in a
    new session, which has an autogroup of its own). Returns what the process now has: pid, sid, nice, autogroup."""
    if nice > 0:
        try:
            os.nice(nice)
        except (OSError, AttributeError):
            pass
        try:
            if AUTOGROUP.exists():
                AUTOGROUP.write_text(str(min(19, nice)))
        except OSError:                    # not permitted, or the kernel has no autogroups
            pass
    info = {"pid": os.getpid(), "sid": os.getsid(0) if hasattr(os, "getsid") else None,
            "nice": os.getpriority(os.PRIO_PROCESS, 0) if hasattr(os, "getpriority") else None}
    info["autogroup"] = read_autogroup()
    return info


def read_autogroup() -> str | None:
    """This process's autogroup as the kernel writes it ("/autogroup-N nice M"), or None where there is none to read
    (no such file, not readable, or empty, as in some sandboxes that report autogroups enabled)."""
    try:
        text = AUTOGROUP.read_text().strip()
    except OSError:
        return None
    return text if text.startswith("/autogroup-") else None


def render_apart(motions: Sequence[MotionSequence], audio: np.ndarray | None, out: str | Path, *,
                 labels: Sequence[str] | None = None, size: tuple[int, int] = (512, 512),
                 body_path: str | Path | None = None, gen_seconds: Sequence[float | None] | None = None,
                 progress: Progress | None = None, nice: int = 19, sr: int = 16000,
                 cancelled: Cancellable | None = None, rig: str | Path | None = None,
                 grounding: bool = True) -> Path:
    """What `render_video(motions, audio, out, ...)` renders (default style), rendered by a child process in its
    own session at niceness `nice` (see the module docstring). Waits for it; returns `out`. `cancelled` (an
    errors.CancelToken, or a predicate) is asked every 0.1 s and at every progress report (~1 % of the frames):
    once cancelled the process is stopped and errors.Cancelled (RenderCancelled) raised. rig: a
    character file (.vrm / .glb / .gltf) whose own mesh is drawn instead of the body (`gesturelsm render --rig`),
    its feet planted on its own legs unless `grounding` is off."""
    import soundfile as sf

    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    job = Path(tempfile.mkdtemp(prefix=".render-job-", dir=out.parent))
    try:
        files = [str(m.save(job / f"motion_{i}.npz")) for i, m in enumerate(motions)]
        cmd = [sys.executable, "-m", "gesturelsm.render.background", "--nice", str(int(nice)), "render", *files,
               "--out", str(out), "--size", f"{int(size[0])}x{int(size[1])}", "--progress-json"]
        if audio is not None:
            sf.write(job / "speech.wav", np.asarray(audio, np.float32), sr, subtype="FLOAT")
            cmd += ["--audio", str(job / "speech.wav")]
        cmd += ["--labels", *labels] if labels else ["--no-labels"]
        if gen_seconds is not None:
            cmd += ["--gen-times", *("-" if g is None else f"{g:.6g}" for g in gen_seconds)]
        if body_path is not None:
            cmd += ["--model", str(body_path)]
        if rig is not None:
            cmd += ["--rig", str(rig)] + ([] if grounding else ["--grounding", "off"])
        _run(cmd, out, job / "stderr.txt", progress, None if cancelled is None else CancelToken.of(cancelled))
    finally:
        shutil.rmtree(job, ignore_errors=True)
    return out


def _run(cmd: list[str], out: Path, err_path: Path, progress: Progress | None,
         cancelled: CancelToken | None) -> None:
    with open(err_path, "w+") as err:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=err, stdin=subprocess.DEVNULL, text=True,
                                start_new_session=True)
        with _lock:
            _running.add(proc)
        killed = threading.Event()
        watcher = _watch(proc, cancelled, killed) if cancelled is not None else None
        try:
            for line in proc.stdout:
                msg = _json(line)
                if "process" in msg:
                    log.info("rendering in process %s", msg["process"])
                    if progress is not None:
                        progress(0.0, "starting: framing the camera on the motions")
                elif "fraction" in msg:
                    if cancelled is not None:
                        cancelled.check(Cancelled, "the render was cancelled")
                    if progress is not None:
                        progress(float(msg["fraction"]), str(msg.get("message", "")))
            code = proc.wait()
            if killed.is_set():
                raise Cancelled("the render was cancelled")
        except BaseException:
            proc.kill()                      # the renderer writes a .part file, renamed when complete: remove it
            proc.wait()
            out.with_name(f".{out.stem}.part{proc.pid}.mp4").unlink(missing_ok=True)   # as render_video names it
            raise
        finally:
            if watcher is not None:
                killed.set()                         # the watcher ends (the process has ended)
                watcher.join()
            with _lock:
                _running.discard(proc)
        err.seek(0)
        text = err.read()
    for note in (ln[len("note: "):] for ln in text.splitlines() if ln.startswith("note: ")
                 and not ln.startswith("note: no --audio")):              # the caller chose a silent video
        warnings.warn(note, RenderWarning, stacklevel=3)    # as render_video warns in-process
    if code != 0:
        log.warning("the render process exited with %s:\n%s", code, text)
        lines = [ln for ln in text.splitlines() if ln.strip() and not ln.startswith("note: ")]
        said = next((ln.split("error: ", 1)[1] for ln in reversed(lines) if "error: " in ln), None)
        raise RenderError(said or f"the render process failed (exit {code}): "
                                  f"{lines[-1] if lines else 'no message'}")


def _watch(proc: subprocess.Popen, cancelled: CancelToken, killed: threading.Event,
           every_s: float = CANCEL_POLL_S) -> threading.Thread:
    """A thread that asks `cancelled` every `every_s` seconds while `proc` runs and kills it at once when it says
    yes (setting `killed`): a cancelled render stops within a fraction of a second, also before its first frame
    (framing the camera on a long motion takes seconds, with no progress line to check at)."""
    def watch() -> None:
        while not killed.wait(every_s) and proc.poll() is None:
            try:
                stop = cancelled.cancelled
            except Exception:
                log.exception("checking whether a render was cancelled failed")
                continue
            if stop:
                killed.set()
                proc.kill()
                return
    thread = threading.Thread(target=watch, name="gesturelsm-render-watch", daemon=True)
    thread.start()
    return thread


def _json(line: str) -> dict:
    line = line.strip()
    if not line.startswith("{"):
        return {}
    try:
        msg = json.loads(line)
    except ValueError:
        return {}
    return msg if isinstance(msg, dict) else {}


@atexit.register
def _stop_all() -> None:
    """Renders still running when the server exits are stopped (they are in sessions of their own, so a Ctrl-C in the
    server's terminal does not reach them)."""
    with _lock:
        procs = list(_running)
    for p in procs:
        p.kill()


def main(argv: list[str] | None = None) -> int:
    """`python -m gesturelsm.render.background --nice N render <gesturelsm render arguments>`: lower this process,
    say so as a JSON line, then become `python -m gesturelsm render <arguments>` (exec: the same process, so its
    session, priority and pid stay), which reports errors as the command line does (exit 2, one line on stderr)."""
    args = list(sys.argv[1:] if argv is None else argv)
    nice = 19
    if len(args) >= 2 and args[0] == "--nice":
        nice, args = int(args[1]), args[2:]
    if args[:1] != ["render"]:
        print("usage: python -m gesturelsm.render.background [--nice N] render <gesturelsm render arguments>",
              file=sys.stderr)
        return 2
    print(json.dumps({"process": lower_this_process(nice)}), flush=True)
    sys.stderr.flush()
    os.execv(sys.executable, [sys.executable, "-m", "gesturelsm", *args])
    return 1                                    # not reached: execv replaces this process or raises OSError


if __name__ == "__main__":
    raise SystemExit(main())
