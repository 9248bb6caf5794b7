"""Many API clients at once on `python -m app --replicas 2`, one replica killed while both make a request
(docs/HOSTILE.md, "Attacks on the service"): does every client get its own motion or one line, and does the front
end stay up with no folder left behind and its memory bounded?

    .venv/bin/python benchmarks/replicas_crowd.py [--clients 10 20] [--seconds 2] [--steps 1] [--checkpoints DIR]
                                                  [--no-kill] [--json out.json]

One front end (this process: the page served with `serve_locally`, as `python -m app` serves it) over two replicas
on a Ray cluster started on this machine (`--cluster local`), the shipped checkpoints unless --checkpoints. For each
client count: that many gradio_client clients, each in its own thread with its own seed, send `/generate` (motion,
video and downloads; `--seconds` of the page's example speech) at once; when both replicas are making a request one
of them is killed (SIGKILL). Then each answer is checked: its motion must be the one this process makes for the
client's seed (never another client's), else the client's error must be one line without a traceback. Reported: the
answers and refusals, wall time first submit to last answer, p50 / max latency, request folders made here against
answers, call folders left on the replicas and whether the dead replica's folder is gone once its replacement runs,
the front end's resident memory before and after (VmRSS; its peak VmHWM; its private part RssAnon, without the
pages of Ray's shared object store it read the replies from) and the largest replica's. The clients and the check
of their motions run in the front end's process too (their threads, their downloads), so its figures are an upper
bound on the server's own. The next
count starts once two replicas are alive again.
"""
from __future__ import annotations

import os

os.environ["GRADIO_ANALYTICS_ENABLED"] = "False"
os.environ["HF_HUB_DISABLE_TELEMETRY"] = "1"
os.environ["RAY_worker_niceness"] = "0"

import argparse
import signal
import statistics
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from _harness import REPO, Rows

EXAMPLE = REPO / "gesturelsm" / "webapp" / "examples" / "hello.wav"
WAIT_S = 1800.0                 # a client's answer is awaited this long at most (a hang shows as "no answer")


def status_mb(pid: int, key: str) -> float:
    """A process's VmRSS / VmHWM (/proc/PID/status) in MiB."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1]) / 1024
    return float("nan")


def replica_pids() -> list[int]:
    import ray._private.state

    return sorted(a["Pid"] for a in ray._private.state.actors(actor_state_name="ALIVE").values()
                  if "GestureReplica" in a["Name"])


def scratch() -> Path:
    from gesturelsm.serve.replicas import SCRATCH

    return Path(tempfile.gettempdir()) / SCRATCH


def calls(pids) -> list[Path]:
    return [p for pid in pids for p in scratch().glob(f"replica-{pid}-*/call-*")]


def wait_for(condition, timeout: float = 900.0, every: float = 0.05) -> bool:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(every)
    return True


@dataclass
class Round:
    clients: int
    answers: dict[int, tuple] = field(default_factory=dict)        # seed -> /generate's outputs
    refusals: dict[int, str] = field(default_factory=dict)         # seed -> the error the client got
    latency: dict[int, float] = field(default_factory=dict)
    wall: float = 0.0
    killed: int | None = None


def crowd(url: str, wav: Path, n: int, steps: int, kill: bool, seed0: int) -> Round:
    """`n` clients at once, each its own seed; one replica killed once both replicas work on a request."""
    from gradio_client import Client, handle_file

    out = Round(n)
    t0 = time.perf_counter()

    def one(seed: int) -> None:
        start = time.perf_counter()
        try:
            client = Client(url, verbose=False, httpx_kwargs={"timeout": WAIT_S})
            job = client.submit(handle_file(str(wav)), "", None, ["gesturelsm"], steps, 2.0, seed, 20, False, "off",
                                256, False, api_name="/generate")
            out.answers[seed] = job.result(timeout=WAIT_S)
        except Exception as exc:                    # the client's side of a refusal (or of a hang: TimeoutError)
            out.refusals[seed] = f"{type(exc).__name__}: {exc}"
        out.latency[seed] = time.perf_counter() - start

    threads = [threading.Thread(target=one, args=(seed0 + i,)) for i in range(n)]
    for t in threads:
        t.start()
    pids = replica_pids()
    if kill and wait_for(lambda: all(any(scratch().glob(f"replica-{p}-*/call-*")) for p in pids)):
        os.kill(pids[0], signal.SIGKILL)
        out.killed = pids[0]
    for t in threads:
        t.join()
    out.wall = time.perf_counter() - t0
    return out


def wrong_motions(service, wav: Path, r: Round, steps: int) -> list[int]:
    """The seeds whose answer is not the motion this process makes for that seed."""
    from gesturelsm.serve.request import Request
    from gesturelsm.serve.service import GestureService

    here = GestureService(service.pipeline, service.settings, service.body)
    wrong = []
    for seed, (video, rows, summary, files, glb) in r.answers.items():
        npz = next((Path(f) for f in files if Path(f).name == "gesturelsm.npz"), None)
        want = here.run(Request(str(wav), methods=["gesturelsm"], steps=steps, cfg=2.0, seed=seed, smoothing="off",
                                render=False, exports=False, transcribe=False)).motions["gesturelsm"]
        with np.load(npz) as d:
            if not Path(video).is_file() or not np.allclose(d["poses"], want.poses, atol=1e-5):
                wrong.append(seed)
    return wrong


def one_round(service, url: str, wav: Path, n: int, args, seed0: int) -> list[str]:
    """A round of `n` clients; returns its table row's cells."""
    front = service.workdir
    before = set(front.glob("req-*"))
    me = os.getpid()
    rss0, anon0 = status_mb(me, "VmRSS"), status_mb(me, "RssAnon")
    r = crowd(url, wav, n, args.steps, not args.no_kill, seed0)
    made = len(set(front.glob("req-*")) - before)
    rss1, anon1, hwm = status_mb(me, "VmRSS"), status_mb(me, "RssAnon"), status_mb(me, "VmHWM")
    wrong = wrong_motions(service, wav, r, args.steps) if args.check else []
    lines = sorted({msg for msg in r.refusals.values()})
    traceback = sum("Traceback" in m or "\n" in m.strip() for m in r.refusals.values())
    replaced = wait_for(lambda: len(replica_pids()) == 2, every=1.0)
    gone = r.killed is None or wait_for(lambda: not any(scratch().glob(f"replica-{r.killed}-*")), every=1.0)
    left = wait_for(lambda: not calls(replica_pids()), 120, every=1.0)
    lat = list(r.latency.values())
    print(f"{n} clients: {len(r.answers)} answered, {len(r.refusals)} refused {lines}", flush=True)
    return [n, "yes" if r.killed else "no", len(r.answers), f"{len(r.refusals)} ({traceback} multi-line)",
            f"{len(wrong)}" if args.check else "not checked", f"{r.wall:.0f}", f"{statistics.median(lat):.0f}",
            f"{max(lat):.0f}", f"{made}", "none" if left else "some", "yes" if gone else "NO",
            "yes" if replaced else "NO",
            f"{rss0:.0f} -> {rss1:.0f} (peak {hwm:.0f}; private {anon0:.0f} -> {anon1:.0f})",
            f"{max(status_mb(p, 'VmRSS') for p in replica_pids()):.0f}"]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--clients", type=int, nargs="+", default=[10, 20])
    p.add_argument("--seconds", type=float, default=2.0, help="seconds of the example speech each client sends")
    p.add_argument("--steps", type=int, default=1)
    p.add_argument("--checkpoints", help="checkpoint folder (default: the shipped ones)")
    p.add_argument("--no-kill", action="store_true", help="kill no replica")
    p.add_argument("--no-check", dest="check", action="store_false",
                   help="do not compare each answer with the motion made here for its seed")
    p.add_argument("--json", help="also write the rows as JSON here")
    args = p.parse_args()

    import soundfile as sf

    from gesturelsm.audio import load_audio
    from gesturelsm.cluster import parse_cluster, parse_replicas
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.replicated import ReplicatedService
    from gesturelsm.webapp.ui import serve_locally

    work = Path(tempfile.mkdtemp(prefix="replicas-crowd-"))
    wav = work / "speech.wav"
    sf.write(wav, load_audio(str(EXAMPLE))[: int(16000 * args.seconds)], 16000)
    settings = ServiceSettings(checkpoints=args.checkpoints, workdir=str(work / "front"), render_nice=0)
    t0 = time.perf_counter()
    service = ReplicatedService.start(settings, parse_replicas("2"), parse_cluster("local"))
    print(f"two replicas started in {time.perf_counter() - t0:.0f} s", flush=True)
    rows = Rows(["clients", "replica killed", "answered", "refused", "wrong motion", "wall s", "p50 s", "max s",
                 "request folders here", "call folders left", "dead one's folder gone", "2 replicas again",
                 "front end MiB", "replica MiB"])
    try:
        demo, url = serve_locally(service)
        try:
            for i, n in enumerate(args.clients):
                rows.add(*one_round(service, url, wav, n, args, seed0=1000 * (i + 1)))
        finally:
            demo.close()
    finally:
        service.close()
    print(rows.markdown())
    if args.json:
        Path(args.json).write_text(rows.json())


if __name__ == "__main__":
    main()
