"""Throughput past one process (docs/CLUSTER.md): study videos per minute for `gesturelsm batch` in this process vs
`--cluster local` (a Ray cluster on this machine's cores), and web requests per minute with the demo in this process,
on 1 and on 2 Ray Serve replicas (`python -m app --replicas N`), at a fixed offered load, with p50 / p95 latency.

    .venv/bin/python benchmarks/cluster_throughput.py [--speeches 4] [--methods gesturelsm ddim] [--size 256]
                                                      [--batch-rounds 1] [--requests 8] [--rate 6]
                                                      [--replicas 0 1 2] [--skip-batch] [--threads N]
                                                      [--json FILE]

Inputs: the page's example speech (eSpeak NG, ~5 s each; the batch cycles through them under new names), the
shipped checkpoints, the built-in mannequin. Batch: every video of speeches x methods, from an empty folder, wall
clock including the start of the Ray cluster and its workers' model loading (printed apart). Web: `--requests` API
calls (`/generate`: motion, video, downloads; one method, audio only, `--size` pixels) submitted open-loop at `--rate`
per minute through gradio_client; latency is submit to answer; throughput is answers per minute from the first
submit to the last answer. Replica memory is the largest resident set of a replica process after the load.

Everything runs at niceness 0 here: Ray starts its workers at 15 (RAY_worker_niceness) and the server renders videos
at 19 (`render_nice`), which on a machine others use measures their load rather than ours.
"""
from __future__ import annotations

import os

os.environ["GRADIO_ANALYTICS_ENABLED"] = "False"
os.environ["HF_HUB_DISABLE_TELEMETRY"] = "1"
os.environ["RAY_worker_niceness"] = "0"

import argparse
import contextlib
import io
import shutil
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
from _harness import REPO, Rows, Stopwatch, cpu_name, json_flag, save_json, set_threads

EXAMPLES = REPO / "gesturelsm" / "webapp" / "examples"



def speech_folder(root: Path, n: int) -> Path:
    d = root / "speech"
    d.mkdir()
    wavs = sorted(EXAMPLES.glob("*.wav"))
    for i in range(n):
        shutil.copy2(wavs[i % len(wavs)], d / f"s{i:02d}_{wavs[i % len(wavs)].name}")
    return d


def batch(speech: Path, out: Path, methods: list[str], size: int, *extra: str) -> float:
    from gesturelsm.cli import main

    with Stopwatch() as clock, contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
        code = main(["batch", "--audio-dir", str(speech), "--methods", *methods, "--out", str(out), "--raters", "1",
                     "--design", "rating",
                     "--size", str(size), *extra])
    if code != 0:
        raise SystemExit(f"gesturelsm batch {' '.join(extra)} failed with status {code}")
    return clock.seconds


def ray_start_seconds() -> float:
    """What `--cluster local` costs before any video: starting Ray and checking its workers."""
    from gesturelsm.cluster import connect, parse_cluster

    with Stopwatch() as clock:
        connect(parse_cluster("local")).close()
    return clock.seconds


def batch_rows(args, root: Path) -> list[tuple]:
    """`--batch-rounds` rounds, each from empty folders, the order of the two runs swapped every round."""
    speech = speech_folder(root, args.speeches)
    n = args.speeches * len(args.methods)
    rows = []
    for r in range(args.batch_rounds):
        runs = [("this process", ()), ("--cluster local", ("--cluster", "local"))]
        for name, extra in runs[::-1] if r % 2 else runs:
            seconds = batch(speech, root / f"r{r}-{len(extra)}", args.methods, args.size, *extra)
            rows.append((f"round {r + 1}: {name}", n, seconds, 60 * n / seconds))
    return rows + [("(Ray start and worker check alone)", 0, ray_start_seconds(), float("nan"))]


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def replica_rss() -> float:
    import ray._private.state

    pids = [a["Pid"] for a in ray._private.state.actors(actor_state_name="ALIVE").values()
            if "GestureReplica" in a["Name"]]
    return max((rss_mb(p) for p in pids), default=float("nan"))


def offered_load(url: str, wav: Path, requests: int, rate: float, size: int) -> tuple[list[float], float]:
    """`requests` /generate calls, the i-th submitted at i * 60 / rate s; -> (latencies, seconds first to last)."""
    from gradio_client import Client, handle_file

    latencies: list[float] = [float("nan")] * requests

    def one(i: int, load: Stopwatch) -> None:
        time.sleep(max(0.0, i * 60.0 / rate - load.elapsed))
        with Stopwatch() as clock:
            client = Client(url, verbose=False, httpx_kwargs={"timeout": 1800})
            client.predict(handle_file(str(wav)), "", None, ["gesturelsm"], 8, 2.0, i, 20, False, "light", size,
                           False, api_name="/generate")
        latencies[i] = clock.seconds

    with Stopwatch() as load:
        threads = [threading.Thread(target=one, args=(i, load)) for i in range(requests)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    return latencies, load.seconds


def app_row(replicas: int, args, work: Path) -> tuple:
    from gesturelsm.cluster import parse_cluster, parse_replicas
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.service import GestureService
    from gesturelsm.webapp.ui import serve_locally

    settings = ServiceSettings(workdir=str(work / f"app{replicas}"), render_nice=0)
    with Stopwatch() as clock:
        if replicas:
            from gesturelsm.serve.replicated import ReplicatedService

            service = ReplicatedService.start(settings, parse_replicas(str(replicas)), parse_cluster("local"))
        else:
            service = GestureService.from_settings(settings)
            service.warmup()
    start = clock.seconds
    try:
        demo, url = serve_locally(service)
        try:
            latencies, seconds = offered_load(url, EXAMPLES / "hello.wav", args.requests, args.rate, args.size)
        finally:
            demo.close()
        memory = replica_rss() if replicas else rss_mb(os.getpid())
    finally:
        if replicas:
            service.close()
    lat = np.asarray(latencies)
    name = f"{replicas} replica(s)" if replicas else "this process (no Ray)"
    return (name, start, 60 * args.requests / seconds, float(np.percentile(lat, 50)), float(np.percentile(lat, 95)),
            memory)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--speeches", type=int, default=4)
    p.add_argument("--methods", nargs="+", default=["gesturelsm", "ddim"])
    p.add_argument("--size", type=int, default=256)
    p.add_argument("--requests", type=int, default=8)
    p.add_argument("--rate", type=float, default=6.0, help="offered load, requests per minute")
    p.add_argument("--batch-rounds", type=int, default=1, help="batch runs of each kind, alternating which goes first")
    p.add_argument("--replicas", type=int, nargs="*", default=[0, 1, 2],
                   help="0: the demo in this process; none given: no web part")
    p.add_argument("--skip-batch", action="store_true")
    p.add_argument("--threads", type=int, default=None, help="torch's math threads here (default: torch's choice)")
    json_flag(p)
    args = p.parse_args()
    if args.threads:
        set_threads(args.threads)
    print(f"machine: {cpu_name()}, {os.cpu_count()} cores; load average at start {os.getloadavg()[0]:.1f}\n")
    tables: dict[str, Rows] = {}
    with tempfile.TemporaryDirectory(prefix="cluster-bench-") as tmp:
        root = Path(tmp)
        if not args.skip_batch:
            table = tables["batch"] = Rows([f"batch: {args.speeches} speeches x {', '.join(args.methods)}, "
                                            f"{args.size} px", "videos", "seconds", "videos per minute"])
            print(table.header())
            for name, n, s, vpm in batch_rows(args, root):
                table.add(name, n, f"{s:.1f}", f"{vpm:.2f}")
                print(table.last(), flush=True)
        if args.replicas:
            table = tables["web"] = Rows([f"web: {args.requests} x /generate at {args.rate:g} per minute, "
                                          f"{args.size} px, ~5 s speech", "start s", "requests per minute",
                                          "p50 latency s", "p95 latency s", "MB per replica"])
            print("\n" + table.header())
            for n in args.replicas:
                name, start, rpm, p50, p95, mb = app_row(n, args, root)
                table.add(name, f"{start:.0f}", f"{rpm:.2f}", f"{p50:.1f}", f"{p95:.1f}", f"{mb:.0f}")
                print(table.last(), flush=True)
    print(f"\nload average at the end {os.getloadavg()[0]:.1f}")
    save_json(args.json, tables)


if __name__ == "__main__":
    main()
