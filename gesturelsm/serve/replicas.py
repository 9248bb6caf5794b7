"""The web demo's generation and rendering as a Ray Serve deployment of N replicas (`python -m app --replicas N`,
docs/CLUSTER.md); the page stays one Gradio front end that calls them (`serve/replicated.py`).

A replica is a `GestureService` of its own with no state a visitor depends on: each call brings its inputs (the
upload's bytes, the request, the motions to render) and takes its outputs back as bytes, which the front end writes
into the visitor's request folder. So replicas need no disk shared with the front end, any replica can take any
call, and a call whose replica died can be made again on another one (generation is deterministic for a seed).

A replica works in a scratch folder of its own under <tmp>/gesturelsm-replicas/, holding an exclusive lock on it
while alive; each call's folder is deleted when the call returns. A replica that starts deletes the scratch folders
whose lock nobody holds: those of replicas that died (killed mid-request, their node lost), on that machine.

Nothing here imports Ray at module level: only `deploy` does, when replicas are asked for.
"""
from __future__ import annotations

import fcntl
import logging
import os
import secrets
import shutil
import tempfile
import time
from collections import OrderedDict
from dataclasses import dataclass, field, replace
from pathlib import Path

from ..asr.source import AutomaticWords
from ..audio import SAMPLE_RATE, load_audio
from ..cluster import Connection, Files, ReplicaCount, require_cpus
from ..errors import ClusterError
from ..retarget import load_character
from ..settings import DEFAULTS
from .config import ServiceSettings
from ..request_files import UPLOADS
from .request import Request, Result
from .service import GestureService

log = logging.getLogger("gesturelsm.app")
APP = "gesturelsm"                       # the Serve application's name (a page on another port: APP-PORT)
SCRATCH = "gesturelsm-replicas"
REPLICA_CPUS = 1.0                       # Ray CPUs reserved per replica (its render process runs beside it, niced)
START_TIMEOUT_S = 600.0                  # replicas load the models and warm up before the first call


@dataclass(frozen=True)
class Upload:
    """A file the visitor sent, by value."""
    name: str
    data: bytes = field(repr=False)


@dataclass(frozen=True)
class Reply:
    """A call's result, its request folder on the replica being `result.job.folder`, and that folder's files."""
    result: Result
    files: dict[str, bytes] = field(repr=False)
    elapsed: float                       # seconds since the request started, when the call returned


@dataclass(frozen=True)
class ReplicaSpec:
    """What every replica is built from: the front end's settings and the files they name, by value."""
    settings: ServiceSettings
    checkpoints: Files | None
    body: Files | None
    warmup: bool = True


class Scratch:
    """This replica's folder, locked while the process lives; `sweep_dead` removes folders nobody holds."""

    def __init__(self, root: Path | None = None):
        self.root = Path(root or Path(tempfile.gettempdir()) / SCRATCH)
        self.root.mkdir(parents=True, exist_ok=True)
        self.removed = sweep_dead(self.root)
        new = Path(tempfile.mkdtemp(prefix=".new-", dir=self.root))
        self._lock = open(new / ".alive", "w")
        fcntl.flock(self._lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        self.folder = new.rename(self.root / f"replica-{os.getpid()}-{secrets.token_hex(4)}")

    def call_folder(self) -> Path:
        path = self.folder / f"call-{secrets.token_hex(8)}"
        path.mkdir()
        return path

    def close(self) -> None:
        """Delete this replica's folder (a replica that stops in order)."""
        shutil.rmtree(self.folder, ignore_errors=True)
        self._lock.close()


def sweep_dead(root: Path) -> int:
    """Delete every replica-* folder under `root` whose lock can be taken (its replica is gone); returns how many."""
    removed = 0
    for folder in root.glob("replica-*"):
        try:
            with open(folder / ".alive", "a") as fh:
                fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
                shutil.rmtree(folder, ignore_errors=True)
                removed += 1
        except BlockingIOError:                 # a live replica holds it
            continue
        except FileNotFoundError:               # removed meanwhile
            continue
    return removed


def _collect(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


class GestureReplica:
    """One replica (a Serve deployment's class): run / edit / render / export / transcribe, each with its inputs by
    value."""

    def __init__(self, spec: ReplicaSpec):
        self.scratch = Scratch()
        if self.scratch.removed:
            log.info("removed the scratch folders of %d replica(s) that died", self.scratch.removed)
        self.takes = self.scratch.folder / "no-take"            # ground truth offered, no take found: an empty folder
        self.takes.mkdir()
        settings = replace(spec.settings, workdir=str(self.scratch.folder / "requests"),
                           checkpoints=str(spec.checkpoints.local()) if spec.checkpoints is not None else None,
                           body_model=str(spec.body.local()) if spec.body is not None else None,
                           beat2=str(self.takes) if spec.settings.beat2 else None)
        self.service = GestureService.from_settings(settings)
        self.characters: OrderedDict[str, object] = OrderedDict()
        if spec.warmup:
            self.service.warmup()

    def pid(self) -> int:
        return os.getpid()

    def __del__(self) -> None:
        """Serve calls this when it stops the replica in order: its scratch folder goes with it."""
        scratch = getattr(self, "scratch", None)
        if scratch is not None:
            scratch.close()

    def run(self, req: Request, audio: Upload, textgrid: Upload | None = None, words: AutomaticWords | None = None,
            take: Files | None = None) -> Reply:
        """`GestureService.run` on the upload; `words`: the transcript the front end already has for it, `take`: the
        ground-truth take the front end found (its two files)."""
        t0 = time.perf_counter()
        folder = self.scratch.call_folder()
        try:
            req = replace(req, audio_path=str(_save(folder, audio)),
                          textgrid_path=str(_save(folder, textgrid)) if textgrid is not None else None)
            if words is not None:
                try:
                    loaded = load_audio(req.audio_path, max_seconds=self.service.settings.max_seconds)
                    self.service.pipeline.remember_transcript(loaded, SAMPLE_RATE, words, req.language)
                except ValueError:                  # the request itself says what is wrong with the audio
                    pass
            service = self.service
            if take is not None:                    # this request's ground truth: a service that sees its take
                service = self.service.with_settings(replace(self.service.settings, beat2=str(take.local())))
            result = service.run(req)
            try:
                return _reply(result, time.perf_counter() - t0)
            finally:
                shutil.rmtree(result.job.folder, ignore_errors=True)
        finally:
            shutil.rmtree(folder, ignore_errors=True)

    def render(self, result: Result, elapsed: float, rig: Files | None = None) -> Reply:
        """`GestureService.render` (on the character whose file `rig` is, if any)."""
        result = self._here(result, elapsed)
        try:
            return _reply(self.service.render(result, character=self._character(rig)),
                          time.perf_counter() - result.job.started)
        finally:
            shutil.rmtree(result.job.folder, ignore_errors=True)

    def edit(self, result: Result, method: str, start, end, regions, seed, elapsed: float) -> Reply:
        """`GestureService.edit` of `result` (sent without the results before it): the reply's folder is the edit's,
        its name the one the front end gives the edit's folder inside the request's."""
        result = self._here(result, elapsed)
        try:
            out = self.service.edit(result, method, start, end, regions, seed)
            return _reply(replace(out, previous=None), time.perf_counter() - out.job.started)
        finally:
            shutil.rmtree(result.job.folder, ignore_errors=True)

    def export(self, result: Result, elapsed: float) -> Reply:
        result = self._here(result, elapsed)
        try:
            return _reply(self.service.export(result), time.perf_counter() - result.job.started)
        finally:
            shutil.rmtree(result.job.folder, ignore_errors=True)

    def transcribe(self, audio: Upload, language: str = DEFAULTS.language) -> AutomaticWords | None:
        """The automatic transcript `run` would make for this upload in `language` (a checked code; the page asks while
        the visitor chooses the settings); None when the audio cannot be used (the request says why)."""
        folder = self.scratch.call_folder()
        try:
            loaded = load_audio(_save(folder, audio), max_seconds=self.service.settings.max_seconds)
            return self.service.pipeline.prefetch_transcript(loaded, SAMPLE_RATE, language)
        except ValueError:
            return None
        finally:
            shutil.rmtree(folder, ignore_errors=True)

    def _here(self, result: Result, elapsed: float) -> Result:
        """The result with a request folder of this replica and its start on this machine's clock."""
        folder = self.scratch.call_folder()
        return replace(result, job=replace(result.job, folder=folder, started=time.perf_counter() - elapsed))

    def _character(self, rig: Files | None):
        if rig is None:
            return None
        if rig.digest not in self.characters:
            self.characters[rig.digest] = load_character(rig.local())
            while len(self.characters) > 4:
                self.characters.popitem(last=False)
        return self.characters[rig.digest]


def _save(folder: Path, upload: Upload) -> Path:
    path = folder / UPLOADS / Path(upload.name).name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(upload.data)
    return path


def _reply(result: Result, elapsed: float) -> Reply:
    return Reply(result, _collect(result.job.folder), elapsed)


def serve_options(count: ReplicaCount, per_replica: int) -> dict:
    """The deployment's Serve options: one CPU and `per_replica` requests per replica; a fixed count, or MIN:MAX
    scaled on the requests each replica has (running and waiting), up after 5 s above the target, down after 2 idle
    minutes."""
    options = dict(ray_actor_options={"num_cpus": REPLICA_CPUS}, max_ongoing_requests=per_replica,
                   health_check_period_s=2, health_check_timeout_s=60, graceful_shutdown_timeout_s=5)
    if count.fixed:
        options["num_replicas"] = count.low
    else:
        options["autoscaling_config"] = dict(min_replicas=count.low, max_replicas=count.high,
                                             target_ongoing_requests=per_replica, upscale_delay_s=5,
                                             downscale_delay_s=120)
    return options


def deploy(spec: ReplicaSpec, count: ReplicaCount, connection: Connection, per_replica: int = 1,
           timeout: float = START_TIMEOUT_S, name: str = APP):
    """Start the replicas as the Serve application `name` on the connected cluster (replacing one of that name, a
    page's earlier run) and wait until they are ready; returns Serve's handle. ClusterError when the cluster has too
    few CPUs for `count.low` replicas or they do not start in `timeout`."""
    from ray import serve

    require_cpus(connection, count.low * REPLICA_CPUS, f"--replicas {count}")
    app = serve.deployment(GestureReplica, name="GestureReplica").options(**serve_options(count, per_replica))
    app = app.bind(spec)
    quiet = {"log_level": "WARNING", "enable_access_log": False}
    logging.getLogger("ray.serve").setLevel(logging.WARNING)          # Serve's progress lines in this process
    serve.start(proxy_location="Disabled", logging_config=quiet)
    logging.getLogger("ray.serve").setLevel(logging.WARNING)          # (serve.start sets its own level)
    serve._run(app, name=name, route_prefix=None, logging_config=quiet, _blocking=False)
    _wait_running(name, timeout)
    return serve.get_app_handle(name)


def _wait_running(name: str, timeout: float) -> None:
    from ray import serve

    deadline = time.monotonic() + timeout
    while True:
        status = serve.status().applications.get(name)
        state = str(getattr(status, "status", "")).rsplit(".", 1)[-1]
        if state == "RUNNING":
            return
        if state in ("DEPLOY_FAILED", "UNHEALTHY"):
            detail = (getattr(status, "message", "") or "").strip().splitlines()
            raise ClusterError(f"the replicas failed to start: {detail[-1] if detail else state}")
        if time.monotonic() > deadline:
            raise ClusterError(f"the replicas did not start within {timeout:.0f} s (see `serve status` on the head)")
        time.sleep(0.5)


def stop(name: str = APP, cluster_goes: bool = False) -> None:
    """Remove the replicas of application `name`, and Serve itself when no other application is left on the cluster
    (the cluster stays up when it was joined). `cluster_goes`: the cluster is stopped next (`--cluster local`), Serve
    with it, so Serve is not shut down on its own first (its controller's shutdown task, killed meanwhile, made Ray
    print retry warnings at every stop)."""
    from ray import serve

    try:
        serve.delete(name)
        if not cluster_goes and not serve.status().applications:
            serve.shutdown()
    except Exception:                            # the cluster is already gone: nothing left to stop
        log.info("stopping the replicas: the cluster was already gone")
    sweep_dead(Path(tempfile.gettempdir()) / SCRATCH)      # those of this machine that were stopped before cleaning


__all__ = ["APP", "GestureReplica", "REPLICA_CPUS", "ReplicaSpec", "Reply", "Scratch", "Upload", "deploy",
           "serve_options", "stop", "sweep_dead"]
