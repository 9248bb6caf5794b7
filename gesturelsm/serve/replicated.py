"""The page's service when generation and rendering run on replicas (`python -m app --replicas N`, serve/replicas.py):
a `GestureService` whose run, render, export and transcript prefetch are calls to the replicas, and everything else
stays here.

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
- the player's payload and the motion statistics, made from the motions the replica returned.

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
from typing import Callable

import numpy as np

from ..asr.languages import AUTO
from ..asr.source import AUTOMATIC, AutomaticWords, transcript_source
from ..audio import load_audio
from ..body.model import resolve_model_path
from ..cluster import ClusterAddress, Connection, Files, ReplicaCount, connect, require_cpus, write_atomic
from ..constants import Progress
from ..data.lookup import find_beat2_take
from ..errors import ClusterError, GestureError
from ..pipeline import GROUND_TRUTH
from ..progress import REQUEST
from ..render.background import RenderCancelled
from . import replicas
from .config import ServiceSettings
from .replicas import ReplicaSpec, Reply, Upload
from .request import Request, Result
from .service import GestureService

log = logging.getLogger("gesturelsm.app")
REMEMBERED = 64                          # prefetched transcripts kept, by upload


class ReplicaLost(GestureError):
    """The replicas making a request died twice in a row."""


class ReplicatedService(GestureService):
    def __init__(self, pipeline, settings: ServiceSettings, body, handle, count: ReplicaCount,
                 connection: Connection | None = None, name: str = replicas.APP):
        super().__init__(pipeline, settings, body)
        self.handle, self.count, self.connection, self.name = handle, count, connection, name
        self._words: OrderedDict[tuple[str, str], AutomaticWords] = OrderedDict()   # by (upload, language)
        self._lock = threading.Lock()

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

    def close(self) -> None:
        replicas.stop(self.name, cluster_goes=self.connection is not None and self.connection.owned)
        if self.connection is not None:
            self.connection.close()

    # ---- the calls -------------------------------------------------------------------------------------------
    def run(self, req: Request, progress: Progress | None = None, audio: np.ndarray | None = None) -> Result:
        if audio is not None:                       # samples in memory: this process's models
            return super().run(req, progress, audio)
        prog = progress or (lambda f, m: None)
        started = time.perf_counter()
        self.cleanup()
        req, plan = self.check(req)
        req = replace(req, language=plan.settings.language)     # checked: the replica remembers the words under it
        upload = _upload(req.audio_path)
        textgrid = _upload(req.textgrid_path) if req.textgrid_path else None
        auto = transcript_source(req.text, bool(req.textgrid_path), plan.settings.transcribe) == AUTOMATIC
        words = self._remembered(upload, req.language) if auto else None
        prog(REQUEST.at("speech"), "generating on a replica")
        reply = self._call("run", req, upload, textgrid, words, self._take(req))
        out = _receive(reply, self.folder(), started)    # the visitor's own folder, as without replicas
        prog(1.0, "done")
        return out

    def _video(self, result: Result, progress: Progress, cancelled: Callable[[], bool], character) -> Result:
        """The video rendered on a replica (`GestureService.render` keeps the queue here: one per page session, a
        closed page's cancelled)."""
        progress(0.0, "rendering on a replica")
        rig = Files.of(character.path, ship=True) if character is not None and character.document is not None \
            else None
        reply = self._call("render", result, time.perf_counter() - result.job.started, rig, cancelled=cancelled)
        return _receive(reply, result.job.folder)

    def export(self, result: Result) -> Result:
        if not result.motions or result.downloads:
            return result
        reply = self._call("export", result, time.perf_counter() - result.job.started)
        return _receive(reply, result.job.folder)

    def prefetch(self, audio_path: str | None, text: str = "", textgrid_path: str | None = None,
                 transcribe: bool = True, ahead: Request | None = None) -> bool:
        """A replica transcribes the upload while the visitor chooses the settings (when the request would: no
        transcript typed, no TextGrid, transcription on); the words go with the request. The rest of the speech is
        prepared on the replica that makes the request; no motion is made ahead (`ahead` is not used: which replica
        takes the click is not known before it, but its language is the one transcribed in)."""
        if not audio_path or transcript_source(text, bool(textgrid_path), transcribe) != AUTOMATIC:
            return False
        try:
            _, plan = self.check(Request(audio_path, language=ahead.language if ahead is not None else AUTO))
            language = plan.settings.language
            upload = _upload(audio_path)
            words = self._call("transcribe", upload, language)
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


__all__ = ["ClusterError", "ReplicaLost", "ReplicatedService"]
