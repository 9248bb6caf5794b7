"""The page's service when generation and rendering run on replicas (`python -m app --replicas N`, serve/replicas.py):
a `GestureService` composed with `ReplicaGeneration`, the port (`serve/port.py` `Generation`) whose run, edit, render,
export and transcript prefetch are calls to the replicas; everything else stays here.

    service = ReplicatedService.start(ServiceSettings(), parse_replicas("2"), parse_cluster("local"))
    ...build_demo(service)...                                           # the page as without replicas
    service.close()                                                     # replicas stopped, the cluster left

What stays in this process, and why:
- every check of a request (the upload's size, every field): a request that would be refused never waits for a
  replica, and the limits a visitor meets (queue, upload size, concurrency, one running video per page, live
  streams, characters) are enforced in one place however many replicas there are;
- the visitor's files: a replica's outputs come back as bytes and are written into the visitor's own request folder
  here (128 random bits in its name, as without replicas), so a visitor never sees another visitor's files and the
  page serves them from there;
- the models for the Live tab: a live stream sends audio every ~100 ms and gets motion back; its state lives in one
  process and a round trip through Ray Serve would add to every chunk, so live sessions run here (LIVE_STREAMS at once);
- the player's payload and the motion statistics, made from the motions the replica returned;
- the Sweep tab's sweeps (`SWEEP_HERE`): a sweep is stopped between two of its motions when its page asks, which a
  call to a replica cannot do, so it runs in this process, on the models loaded for the Live tab (the page says so).

A call whose replica dies (killed, its node lost) is made once more, on a replica that is alive (Serve replaces the
dead one); generation is deterministic for a seed, so the visitor gets the same motion. A second loss is one line.
"""
from __future__ import annotations

import hashlib
import logging
import threading
import time
from collections import OrderedDict
from dataclasses import replace
from pathlib import Path
from typing import Callable, Iterator, Sequence

import numpy as np

from ..asr.languages import AUTO
from ..asr.source import AUTOMATIC, AutomaticWords, transcript_source
from ..audio import load_audio
from ..body.model import resolve_model_path
from ..cluster import ClusterAddress, Connection, Files, ReplicaCount, connect, require_cpus, write_atomic
from ..constants import Progress
from ..data.lookup import find_beat2_take
from ..errors import ClusterError, GestureError
from ..evaluation.sweep import SweepLimits
from ..pipeline import GROUND_TRUTH
from ..progress import REQUEST
from ..render.background import RenderCancelled
from . import replicas
from .config import ServiceSettings
from .editing import root_folder
from .local import LocalGeneration
from .replicas import ReplicaSpec, Reply, Upload
from .request import Request, Result
from .service import GestureService
from .sweep import SweepOutcome, SweepRequest

log = logging.getLogger("gesturelsm.app")
REMEMBERED = 64                          # prefetched transcripts kept, by upload


class ReplicaLost(GestureError):
    """The replicas making a request died twice in a row."""


SWEEP_HERE = ("Sweeps run in the page's own process on this server (its models for the Live tab): Generate, Edit, "
              "the videos and the downloads run on the replicas.")


class ReplicaGeneration:
    """`Generation` on Ray Serve replicas (module docstring); `local`: this process's, for samples sent in memory
    and for sweeps."""

    def __init__(self, local: LocalGeneration, handle, count: ReplicaCount | None,
                 connection: Connection | None = None, name: str = replicas.APP):
        self.local, self.handle, self.count, self.connection, self.name = local, handle, count, connection, name
        self.intake, self.folders, self.settings = local.shop.intake, local.shop.folders, local.settings
        self.call = self._call                      # a call to a replica (tests give another)
        self._words: OrderedDict[tuple[str, str], AutomaticWords] = OrderedDict()   # by (upload, language)
        self._lock = threading.Lock()

    sweep_note = SWEEP_HERE

    @property
    def where(self) -> str:
        return f"{self.count} replica(s)" if self.count is not None else "replicas"

    def close(self) -> None:
        replicas.stop(self.name, cluster_goes=self.connection is not None and self.connection.owned)
        if self.connection is not None:
            self.connection.close()

    # ---- the calls -------------------------------------------------------------------------------------------
    def run(self, req: Request, progress: Progress | None = None, audio: np.ndarray | None = None) -> Result:
        if audio is not None:                       # samples in memory: this process's models
            return self.local.run(req, progress, audio)
        prog = progress or (lambda f, m: None)
        started = time.perf_counter()
        self.folders.cleanup()
        req, plan = self.intake.check(req)
        req = replace(req, language=plan.settings.language)     # checked: the replica remembers the words under it
        upload = _upload(req.audio_path)
        textgrid = _upload(req.textgrid_path) if req.textgrid_path else None
        auto = transcript_source(req.text, bool(req.textgrid_path), plan.settings.transcribe) == AUTOMATIC
        words = self._remembered(upload, req.language) if auto else None
        prog(REQUEST.at("speech"), "generating on a replica")
        reply = self.call("run", req, upload, textgrid, words, self._take(req))
        out = _receive(reply, self.folders.new(), started)    # the visitor's own folder, as without replicas
        prog(1.0, "done")
        return out

    def stream(self, req: Request, progress: Progress | None = None, audio: np.ndarray | None = None,
               previews: bool = True) -> Iterator[Result]:
        """One result, once a replica has made every method."""
        return iter([self.run(req, progress, audio)])

    def edit(self, result: Result, method: str, start, end, regions: Sequence[str] | str, seed,
             progress: Progress | None = None) -> Result:
        """The edit made on a replica, from the result without the ones before it; its folder (empty until the
        video and the downloads) inside the request's here, and `previous` the result edited."""
        prog = progress or (lambda f, m: None)
        if result is None or not result.motions:
            return self.local.edit(result, method, start, end, regions, seed, progress)   # the visitor's line
        prog(0.05, "editing on a replica")
        sent = replace(result, previous=None, video=None, downloads=(), glb=None)
        reply = self.call("edit", sent, method, start, end, regions, seed,
                          time.perf_counter() - result.job.started)
        folder = root_folder(result) / reply.result.job.folder.name
        folder.mkdir(parents=True, exist_ok=True)
        out = _receive(reply, folder)
        prog(1.0, "done")
        return replace(out, previous=result)

    def render(self, result: Result, progress: Progress, cancelled: Callable[[], bool], character=None) -> Result:
        """The video rendered on a replica (`GestureService.render` keeps the queue here: one per page session, a
        closed page's cancelled)."""
        progress(0.0, "rendering on a replica")
        rig = Files.of(character.path, ship=True) if character is not None and character.document is not None \
            else None
        reply = self.call("render", result, time.perf_counter() - result.job.started, rig, cancelled=cancelled)
        return _receive(reply, result.job.folder)

    def export(self, result: Result) -> Result:
        if not result.motions or result.downloads:
            return result
        reply = self.call("export", result, time.perf_counter() - result.job.started)
        return _receive(reply, result.job.folder)

    def sweep(self, req: SweepRequest, limits: SweepLimits, progress: Progress | None,
              cancelled: Callable[[], bool] | None) -> SweepOutcome:
        """In this process (`SWEEP_HERE`)."""
        return self.local.sweep(req, limits, progress, cancelled)

    def prefetch(self, audio_path: str | None, text: str = "", textgrid_path: str | None = None,
                 transcribe: bool = True, ahead: Request | None = None) -> bool:
        """A replica transcribes the upload while the visitor chooses the settings (when the request would: no
        transcript typed, no TextGrid, transcription on); the words go with the request. The rest of the speech is
        prepared on the replica that makes the request; no motion is made ahead (`ahead` is not used: which replica
        takes the click is not known before it, but its language is the one transcribed in)."""
        if not audio_path or transcript_source(text, bool(textgrid_path), transcribe) != AUTOMATIC:
            return False
        try:
            _, plan = self.intake.check(Request(audio_path, language=ahead.language if ahead is not None else AUTO))
            language = plan.settings.language
            upload = _upload(audio_path)
            words = self.call("transcribe", upload, language)
        except GestureError as exc:
            log.info("no transcript prefetched for %s: %s", Path(audio_path).name, " | ".join(str(exc).splitlines()))
            return False
        if words is None:
            return False
        with self._lock:
            self._words[(_digest(upload), language)] = words
            while len(self._words) > REMEMBERED:
                self._words.popitem(last=False)
        return True

    # ---- helpers ---------------------------------------------------------------------------------------------
    def _remembered(self, upload: Upload, language: str = AUTO) -> AutomaticWords | None:
        with self._lock:
            return self._words.get((_digest(upload), language))

    def _take(self, req: Request) -> Files | None:
        """Ground truth asked for: the BEAT2 take this speech is (the folder is here), its two files by value."""
        if not self.settings.beat2 or GROUND_TRUTH not in (req.methods or ()):
            return None
        try:
            audio = load_audio(req.audio_path, max_seconds=self.settings.max_seconds)
        except ValueError:                          # the replica refuses the audio with its message
            return None
        name = find_beat2_take(self.settings.beat2, audio, Path(req.audio_path).name)
        return None if name is None else Files.of(self.settings.beat2, ship=True,
                                                  only=[f"smplxflame_30/{name}.npz", f"wave16k/{name}.wav"])

    def _call(self, method: str, *args, cancelled: Callable[[], bool] | None = None):
        """`method` on a replica; once more on another if its replica died. A visitor's error comes back as itself."""
        from ray.exceptions import RayActorError, RayTaskError

        for attempt in (1, 2):
            response = getattr(self.handle, method).remote(*args)
            try:
                return _wait(response, cancelled)
            except RayTaskError as exc:
                if isinstance(exc.cause, GestureError):
                    raise exc.cause from None
                raise
            except RayActorError as exc:
                if attempt == 2:
                    raise ReplicaLost("The server lost the worker making this twice; please try again.") from None
                log.warning("a replica died during a %s call (%s); making it again on another", method,
                            type(exc).__name__)


class ReplicatedService(GestureService):
    """A `GestureService` on `ReplicaGeneration` (the constructor composes it; nothing of the service is changed)."""

    def __init__(self, pipeline, settings: ServiceSettings, body, handle, count: ReplicaCount | None,
                 connection: Connection | None = None, name: str = replicas.APP):
        super().__init__(pipeline, settings, body,
                         generation=lambda local: ReplicaGeneration(local, handle, count, connection, name))

    @classmethod
    def start(cls, settings: ServiceSettings, count: ReplicaCount, address: ClusterAddress,
              warmup: bool = True, name: str = replicas.APP) -> "ReplicatedService":
        """Join or start the cluster, start the replicas (each with `settings.concurrency` requests at a time) as the
        Serve application `name` (one per page on a shared cluster), and load the models here for the Live tab; the
        page then takes count.high x concurrency requests at once."""
        conn = connect(address)
        deploying = False
        try:
            require_cpus(conn, count.low * replicas.REPLICA_CPUS, f"--replicas {count}")     # before any loading
            here = GestureService.from_settings(settings)
            spec = ReplicaSpec(settings, Files.of(settings.checkpoints, ship=True),
                               Files.of(resolve_model_path(settings.body_model), ship=True), warmup)
            deploying = True
            handle = replicas.deploy(spec, count, conn, per_replica=settings.concurrency, name=name)
        except BaseException:
            if deploying:
                replicas.stop(name)
            conn.close()
            raise
        page = replace(settings, concurrency=count.high * settings.concurrency)
        return cls(here.pipeline, page, here.body, handle, count, conn, name)


def _wait(response, cancelled: Callable[[], bool] | None):
    """The response's value; `cancelled()` asked every 0.2 s stops waiting and cancels the call (RenderCancelled)."""
    while True:
        try:
            return response.result(timeout_s=0.2 if cancelled is not None else 1.0)
        except TimeoutError:
            if cancelled is not None and cancelled():
                response.cancel()
                raise RenderCancelled("the page asked for newer motion") from None


def _upload(path: str | Path) -> Upload:
    return Upload(Path(path).name, Path(path).read_bytes())


def _digest(upload: Upload) -> str:
    return hashlib.blake2b(upload.data, digest_size=16).hexdigest()


def _receive(reply: Reply, folder: Path, started: float | None = None) -> Result:
    """The replica's files written into the visitor's `folder` (each whole), and its result pointing at them."""
    old = reply.result.job.folder
    for name, data in reply.files.items():
        write_atomic(folder / name, data)

    def here(path: Path | None) -> Path | None:
        if path is None:
            return None
        path = Path(path)
        return folder / path.relative_to(old) if path.is_relative_to(old) else path

    start = time.perf_counter() - reply.elapsed if started is None else started
    result = reply.result
    return replace(result, video=here(result.video), downloads=tuple(here(p) for p in result.downloads),
                   glb=here(result.glb), job=replace(result.job, folder=folder, started=start))


__all__ = ["ClusterError", "ReplicaGeneration", "ReplicaLost", "ReplicatedService", "SWEEP_HERE"]
