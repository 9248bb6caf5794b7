"""`gesturelsm serve` (installed) and `python -m app` (a checkout): the web demo, same flags.

The flags' defaults come from environment variables (the description below lists them). Gradio's analytics and
the Hugging Face hub's telemetry are switched off, and the hub set offline unless asked otherwise, when the demo
starts, before Gradio is imported (not when the `gesturelsm` command line merely lists its subcommands).
"""
from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import time

from gesturelsm.cluster import cluster_argument, parse_cluster, replicas_argument
from gesturelsm.errors import GestureError
from gesturelsm.serve.config import QUEUE_SIZE, ServiceSettings

NAME = "serve"
HELP = "serve the web demo (as `python -m app` in a checkout)"

DESCRIPTION = """`{prog}`: start the web demo on http://127.0.0.1:7860 (built-in mannequin, shipped checkpoints).

Every flag has an environment variable (flag wins): GESTURELSM_HOST, GESTURELSM_PORT, GESTURELSM_SMPLX_MODEL,
GESTURELSM_CHECKPOINTS, GESTURELSM_BEAT2, GESTURELSM_MAX_SECONDS, GESTURELSM_MAX_UPLOAD_MB,
GESTURELSM_KEEP_MINUTES, GESTURELSM_CONCURRENCY, GESTURELSM_QUEUE_SIZE, GESTURELSM_WORKDIR, GESTURELSM_THREADS,
GESTURELSM_REPLICAS, GESTURELSM_CLUSTER. No telemetry: Gradio analytics and the Hugging Face hub's telemetry are
switched off before Gradio is imported.

Replicas (docs/CLUSTER.md): `--replicas N` runs generation and rendering in N Ray Serve replicas (`MIN:MAX`: as many
as the queue asks for), each taking --concurrency requests at a time, on `--cluster` (default local: this machine's
cores); the page stays here, one front end, with the Live tab's streams. Without --replicas nothing of Ray is loaded.

Logging (stderr): one line per refused request (what the visitor must change), per expired-file sweep and
at shutdown; full tracebacks only for server errors.
"""


def _env(name: str, default=None):
    v = os.environ.get(name)
    return v if v not in (None, "") else default


def add_arguments(p: argparse.ArgumentParser) -> argparse.ArgumentParser:
    d = ServiceSettings()
    p.add_argument("--host", default=_env("GESTURELSM_HOST", "127.0.0.1"),
                   help="address to bind (default 127.0.0.1; 0.0.0.0 serves the network)")
    p.add_argument("--port", type=int, default=int(_env("GESTURELSM_PORT", 7860)), help="port (default 7860)")
    p.add_argument("--model", default=_env("GESTURELSM_SMPLX_MODEL"),
                   help="SMPL-X .npz body model (default: the built-in mannequin)")
    p.add_argument("--checkpoints", default=_env("GESTURELSM_CHECKPOINTS"),
                   help="folder with tokenizer/ and generator/ checkpoints (default: shipped assets/)")
    p.add_argument("--beat2", default=_env("GESTURELSM_BEAT2"),
                   help="BEAT2-layout folder: offers ground truth when the speech is one of its takes")
    p.add_argument("--max-seconds", type=float, default=float(_env("GESTURELSM_MAX_SECONDS", d.max_seconds)),
                   help=f"longest speech accepted, seconds (default {d.max_seconds:g})")
    p.add_argument("--max-upload-mb", type=float, default=float(_env("GESTURELSM_MAX_UPLOAD_MB", d.max_upload_mb)),
                   help=f"largest upload, MB (default {d.max_upload_mb:g})")
    p.add_argument("--keep-minutes", type=float, default=float(_env("GESTURELSM_KEEP_MINUTES", d.keep_minutes)),
                   help=f"delete generated files after this many minutes (default {d.keep_minutes:g})")
    p.add_argument("--concurrency", type=int, default=int(_env("GESTURELSM_CONCURRENCY", d.concurrency)),
                   help=f"requests processed at once; the rest wait in the queue (default {d.concurrency})")
    p.add_argument("--queue-size", type=int, default=int(_env("GESTURELSM_QUEUE_SIZE", QUEUE_SIZE)),
                   help=f"requests that may wait; beyond that visitors get 'Queue is full' (default {QUEUE_SIZE})")
    p.add_argument("--workdir", default=_env("GESTURELSM_WORKDIR"), help="output folder (default <tmp>/gesturelsm-app)")
    p.add_argument("--threads", type=int, default=int(_env("GESTURELSM_THREADS", 1)),
                   help="math threads per request and per live stream (default 1: on 2 cores a generator step is "
                   "fastest on one, and two oversubscribe a machine that also runs a browser)")
    p.add_argument("--no-warmup", action="store_true", help="skip the warm-up generation at start")
    p.add_argument("--no-ahead", action="store_true",
                   help="do not make the motion of the settings shown before Generate is clicked (by default the page "
                   "makes it while the visitor reads the settings, when the server is idle, and a click asking for the "
                   "same shows it at once)")
    p.add_argument("--replicas", type=replicas_argument, default=_env("GESTURELSM_REPLICAS"), metavar="N|MIN:MAX",
                   help="generate and render in N Ray Serve replicas (MIN:MAX autoscales on the queue); default: in "
                        "this process")
    p.add_argument("--cluster", type=cluster_argument, default=_env("GESTURELSM_CLUSTER"),
                   metavar="local|auto|ray://HOST:PORT",
                   help="where the replicas run: local (start Ray on this machine's cores, the default), auto (the "
                        "cluster `ray start --head` started here) or ray://HOST:PORT")
    p.add_argument("--vmc", default=_env("GESTURELSM_VMC"), metavar="HOST:PORT",
                   help="send the Live tab's stream (one at a time) as VMC protocol bundles to HOST:PORT (VSeeFace, "
                   "VNyan, Warudo, EVMC4U ...: docs/ENGINES.md); visitors cannot change where")
    p.add_argument("--livelink", default=_env("GESTURELSM_LIVELINK"), metavar="HOST:PORT",
                   help="send the Live tab stream's face as Live Link Face packets to HOST:PORT (Unreal)")
    return p


def engine_relay(args: argparse.Namespace):
    """The operator's EngineRelay from --vmc / --livelink (None without them); a bad address is a GestureError."""
    if not (getattr(args, "vmc", None) or getattr(args, "livelink", None)):
        return None
    from gesturelsm.export.engine_stream import parse_address   # late, as the service: they load torch
    from gesturelsm.live.relay import EngineRelay

    vmc = parse_address(args.vmc, "--vmc") if args.vmc else None
    livelink = parse_address(args.livelink, "--livelink") if args.livelink else None
    return EngineRelay(vmc, livelink, body=args.model)


def build_parser(prog: str = "python -m app") -> argparse.ArgumentParser:
    return add_arguments(argparse.ArgumentParser(prog=prog, description=DESCRIPTION.format(prog=prog),
                                                 formatter_class=argparse.RawDescriptionHelpFormatter))


def add_parser(subparsers) -> None:
    """`gesturelsm serve`: the `gesturelsm` command line's entry to the demo."""
    p = subparsers.add_parser(NAME, help=HELP,
                              description=DESCRIPTION.format(prog="gesturelsm serve"),
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(p).set_defaults(func=lambda args: run_demo(args, "gesturelsm serve"))


class Stop(BaseException):
    """Ctrl-C or SIGTERM: the server stops (a BaseException, as KeyboardInterrupt, so no handler takes it for an
    error)."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum

    @property
    def what(self) -> str:
        return "Ctrl-C" if self.signum == signal.SIGINT else signal.Signals(self.signum).name


def _stop_signal(signum, frame) -> None:
    raise Stop(signum)


class Stages:
    """The start-up's lines on stdout: one per stage as it begins, with the seconds since the start."""

    def __init__(self, prog: str, out=None):
        self.prog, self.out, self.t0 = prog, out, time.perf_counter()

    def say(self, line: str) -> None:
        print(f"{self.prog}: [{time.perf_counter() - self.t0:5.1f} s] {line}", file=self.out or sys.stdout,
              flush=True)


def run_demo(args: argparse.Namespace, prog: str) -> int:
    """Load the models, warm them up, and serve the page until stopped (Ctrl-C or SIGTERM), saying each start-up
    stage as it begins and how it stopped."""
    os.environ["GRADIO_ANALYTICS_ENABLED"] = "False"
    os.environ["HF_HUB_DISABLE_TELEMETRY"] = "1"
    os.environ.setdefault("HF_HUB_OFFLINE", "1")
    logging.basicConfig(level=logging.WARNING, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    logging.getLogger("gesturelsm").setLevel(logging.INFO)
    # lazy (the service in `page_service`, .ui in `_serve`): the service loads torch, .ui imports gradio; `--help` and
    # bad arguments answer without them
    settings = ServiceSettings(checkpoints=args.checkpoints, body_model=args.model, beat2=args.beat2,
                               workdir=args.workdir, max_seconds=args.max_seconds, max_upload_mb=args.max_upload_mb,
                               keep_minutes=args.keep_minutes, concurrency=max(1, args.concurrency),
                               threads=max(1, args.threads), ahead=not args.no_ahead)
    stages = Stages(prog)
    handlers = _handle_stops()
    service = None
    try:
        try:
            engines = engine_relay(args)
            service = page_service(args, settings, stages)
        except GestureError as exc:                          # one line each
            print(f"{prog}: error: {exc}", file=sys.stderr)
            return 2
        _serve(service, args, stages, engines)
    except (Stop, KeyboardInterrupt) as stop:
        what = stop.what if isinstance(stop, Stop) else "Ctrl-C"
        stages.say(f"stopping ({what}) while starting")
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)        # a second Ctrl-C does not cut the clean-up short
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        try:
            if args.replicas and service is not None:
                stages.say("stopping the replicas")
                _quiet_ray_on_stop()
                service.close()                             # the replicas stop; a joined cluster stays up
        finally:
            _restore(handlers)
    stages.say("stopped")
    return 0


def _handle_stops() -> dict:
    """Ctrl-C and SIGTERM stop the server the same way (outputs deleted, one line); returns the handlers before."""
    try:
        return {s: signal.signal(s, _stop_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    except ValueError:                                     # not the main thread (a test): Python's own handling
        return {}


def _restore(handlers: dict) -> None:
    for s, h in handlers.items():
        signal.signal(s, h)


def _quiet_ray_on_stop() -> None:
    """Stopping: Ray's own loggers say only errors (its workers' reconnect retries while the local cluster goes down
    are not news to the one who stopped it)."""
    os.environ.setdefault("RAY_BACKEND_LOG_LEVEL", "error")
    for name in ("ray", "ray.serve", "ray._private", "ray.util", "ray._raylet"):
        logging.getLogger(name).setLevel(logging.ERROR)


def page_service(args: argparse.Namespace, settings, stages: "Stages | None" = None):
    """The page's service: in this process, or with --replicas over Ray Serve replicas on --cluster."""
    say = stages.say if stages is not None else (lambda line: None)
    if args.cluster and not args.replicas:
        raise GestureError("--cluster says where replicas run: give --replicas N too")
    if args.replicas:
        say(f"starting {args.replicas} replica(s) on the Ray cluster ({args.cluster or 'local'}): each loads the models"
            + ("" if args.no_warmup else " and warms up") + "; the models for the Live tab load here")
        from gesturelsm.serve.replicated import ReplicatedService

        return ReplicatedService.start(settings, args.replicas, args.cluster or parse_cluster("local"),
                                       warmup=not args.no_warmup, name=f"gesturelsm-{args.port}")
    say("loading the models (" + (f"checkpoints {args.checkpoints}" if args.checkpoints else "shipped checkpoints")
        + ", " + (f"body {args.model}" if args.model else "built-in mannequin") + ")")
    from gesturelsm.serve.service import GestureService

    return GestureService.from_settings(settings)


def _serve(service, args: argparse.Namespace, stages: Stages, engines=None) -> None:
    if not args.no_warmup:
        stages.say("warming up: one generation per speech length and method, so the first visitor waits for none "
                   "of it (--no-warmup skips it)")
        service.warmup()
    stages.say("building the page")
    from gesturelsm.webapp.ui import build_demo

    demo = build_demo(service, max(1, args.queue_size), engines)
    try:                                                     # a stop from here on closes the page
        stages.say(f"starting the web server on {args.host}:{args.port}")
        demo.launch(host=args.host, port=args.port, prevent_thread_lock=True, quiet=True)
        stages.say(f"ready: methods {', '.join(service.methods)}; open http://{args.host}:{args.port} (Ctrl-C stops)")
        while True:                                          # until Ctrl-C or SIGTERM (Stop)
            time.sleep(3600)
    except (Stop, KeyboardInterrupt) as stop:
        what = stop.what if isinstance(stop, Stop) else "Ctrl-C"
        signal.signal(signal.SIGINT, signal.SIG_IGN)        # a second Ctrl-C does not cut the clean-up short
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        stages.say(f"stopping ({what}): closing the page and deleting its output files")
    finally:
        demo.close()


def main(argv: list[str] | None = None, prog: str = "python -m app") -> int:
    return run_demo(build_parser(prog).parse_args(argv), prog)
