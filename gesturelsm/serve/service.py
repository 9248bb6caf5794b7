"""What the web app does for one request, without any UI: the page (`gesturelsm/webapp/`) and its tests call
this.

    service = GestureService.from_settings(ServiceSettings())           # shipped checkpoints, mannequin
    out = service.run(Request(audio_path="speech.wav", text="what was said",
                              methods=("gesturelsm", "ddim", "ground_truth")))
    out.video, out.rows, out.downloads, out.glb, out.text_mode

One request = load the upload -> prepare the speech once (features, word timings; usually done at the upload by
`prefetch`) -> generate per method, fewest steps first -> post-process (stand in place, smoothing, feet on the ground)
-> render all methods side by side with the speech -> exports -> one timing row per method and stage. Generation and
post-processing are the library's one request flow (`pipeline.generate_each`, `settings.PostProcess`); `stream` gives
the result after each method (`serve/progressive.py`). The service is composed: the upload's checks and its speech
(`serve/intake.py`), the request folders (`request_files.py`), the runs made ahead (`serve/ahead.py`), the render queue
(`serve/renders.py`), and the port its requests, edits, sweeps, videos and downloads are made through
(`serve/port.py` `Generation`: in this process, `serve/local.py`, or on Ray Serve replicas, `serve/replicated.py`).
A request run with `render=False` returns its `Result` at once; `render(result)` and `export(result)` then return new
results with the video and the downloads (`serve/request.py`). Every problem a
visitor can fix raises an `errors.GestureError` with a message meant for the page.
"""
from __future__ import annotations

import copy
import logging
import tempfile
import time
from pathlib import Path
from typing import Callable, Hashable, Iterator, Sequence

import numpy as np
import torch

from ..align import Word
from ..asr.source import warm_up as warm_words
from ..audio import SAMPLE_RATE
from ..body import load_body_model
from ..body.model import resolve_model_path
from ..constants import Progress
from ..evaluation.sweep import SweepLimits
from ..backends import checkpoint_sources
from ..pipeline import GesturePipeline, Plan, SpeechInput
from ..settings import Limits
from .ahead import Ahead
from .config import ServiceSettings
from .intake import Intake
from .local import LocalGeneration, in_turn
from ..request_files import RequestFolders
from .port import Generation
from .prepared import PreparedUploads
from .renders import RenderQueue
from .request import Request, Result
from .sweep import SweepOutcome, SweepRequest
from .workshop import Workshop

log = logging.getLogger("gesturelsm.app")
WARMUP_SECONDS = (1, 4, 8, 15, 30, 60)      # speech lengths the warm-up generates for: 1-16 windows (kernel shapes)
Busy = Callable[[], bool]


# ---- the service -------------------------------------------------------------------------------------------
class GestureService:
    """One server's requests (module docstring). `generation`: where they are made, given the local one (this
    process's; None: that one); `busy`: whether something else needs the cores (no motion is made ahead then; more
    signals: `set_busy`)."""

    def __init__(self, pipeline, settings: ServiceSettings = ServiceSettings(), body=None,
                 generation: Callable[[LocalGeneration], Generation] | None = None, busy: Busy | None = None):
        self.pipeline = pipeline
        self.settings = settings
        self.body = body
        self.folders = RequestFolders(settings.workdir or Path(tempfile.gettempdir()) / "gesturelsm-app",
                                      settings.keep_minutes)
        self.workdir = self.folders.workdir
        self.uploads = PreparedUploads()            # uploads decoded and prepared before the click (prefetch)
        self._busy: list[Busy] = [busy] if busy is not None else []
        self.ahead = Ahead(self.busy)               # motion made before the click for the page's settings (prefetch)
        self.renders = RenderQueue(settings.concurrency)   # videos: this many at once, the rest wait (serve/renders.py)
        self.intake = Intake(pipeline, settings, self.uploads)
        self.local = LocalGeneration(Workshop(pipeline, body, self.intake, self.ahead, self.folders, settings.threads),
                                     settings, self.renders)
        self.generation: Generation = generation(self.local) if generation is not None else self.local

    @classmethod
    def from_settings(cls, settings: ServiceSettings = ServiceSettings()) -> "GestureService":
        pipe = GesturePipeline.from_pretrained(checkpoints=checkpoint_sources(settings.checkpoints),
                                               max_seconds=settings.max_seconds)
        body = load_body_model(str(resolve_model_path(settings.body_model)))
        return cls(pipe, settings, body)

    def with_settings(self, settings: ServiceSettings) -> "GestureService":
        """This service, generating here, with other settings (e.g. another BEAT2 folder for one request): its models,
        uploads, runs made ahead, request folders and render queue shared."""
        other = copy.copy(self)
        other.settings = settings
        other.intake = Intake(self.pipeline, settings, self.uploads)
        other.local = LocalGeneration(Workshop(self.pipeline, self.body, other.intake, self.ahead, self.folders,
                                               settings.threads), settings, self.renders)
        other.generation = other.local
        return other

    def set_busy(self, busy: Busy) -> None:
        """Another signal that something else needs the cores (e.g. the page's live streams): while it says so, no
        motion is made ahead and a run not yet taken stops (`serve/ahead.py`)."""
        self._busy.append(busy)

    def busy(self) -> bool:
        return any(signal() for signal in list(self._busy))

    @property
    def limits(self) -> Limits:
        """What this server accepts beyond each method's own bounds (`Intake.limits`)."""
        return self.intake.limits

    @property
    def methods(self) -> list[str]:
        """Choices for the page: the loaded generators in registry order, then ground truth when a BEAT2 folder is
        set."""
        return self.intake.methods

    @property
    def where(self) -> str:
        """Where requests, edits, videos and sweeps are made (`Generation.where`), for the page."""
        return self.generation.where

    def close(self) -> None:
        """Stop what the generation started (replicas; a cluster this process started)."""
        self.generation.close()

    # ---- housekeeping ----------------------------------------------------------------------------------
    def warmup(self, seconds: tuple[float, ...] = WARMUP_SECONDS) -> float:
        """Load the text encoder and the speech recogniser and run each generator once (1 step) on a tone of each
        length in `seconds`, and the recogniser once, so the first visitor waits for none of it: the fast kernels
        measure each new tensor shape at its first call (gesturelsm/kernels, ~1-3 s per method on a machine whose
        choices are not cached yet), and the shapes grow with the speech (one window per 28 latents, speech features
        for up to 16 windows at once, decoding up to 512 latents), so the lengths cover every size class a request
        and a live stream use (lengths past the server's limit are left out); returns the seconds it took."""
        t0 = time.perf_counter()
        torch.set_num_threads(self.settings.threads)       # the kernels' choices are kept per thread count
        for sec in [s for s in seconds if s <= self.pipeline.max_seconds] or [1.0]:
            n = int(sec * SAMPLE_RATE)
            y = (0.3 * np.sin(np.arange(n) / SAMPLE_RATE * 2 * np.pi * 180)).astype(np.float32)
            speech = self.pipeline.prepare_speech(y, SAMPLE_RATE, words=_warmup_words())
            for m in self.pipeline.methods:
                self.pipeline.generate(speech, steps=1, method=m, output="raw")
        warm_words(y[:SAMPLE_RATE])                          # says "unavailable" itself when not installed
        return time.perf_counter() - t0

    def prefetch(self, audio_path: str | None, text: str = "", textgrid_path: str | None = None,
                 transcribe: bool = True, ahead: Request | None = None) -> bool:
        """Prepare an upload before the visitor asks for it (the page calls this when speech is uploaded or recorded,
        and when the transcript or the settings change): the file decoded and the speech prepared for those transcript
        settings (features, the words typed / from the TextGrid / recognised and their timings), remembered so that
        Generate only generates (`serve/prepared.py`); then, with `ahead` (the request the page's settings make at
        this moment), its motion is made in the background for a click that asks for the same (`serve/ahead.py`).
        Never raises: a file or settings that cannot be used are left for the request to refuse with its message.
        Returns whether the speech is ready (automatic words may still be being recognised on their thread)."""
        return self.generation.prefetch(audio_path, text, textgrid_path, transcribe, ahead)

    def make_ahead(self, req: Request):
        """Start making `req`'s motion in the background in this process (`serve/ahead.py`); the run, or None where
        none is started (the server is busy, or such a run exists; or the server is set not to:
        `ServiceSettings.ahead`). Raises the request's GestureError when it would be refused."""
        return self.local.make_ahead(req)

    def motion_key(self, req: Request, plan: Plan) -> Hashable:
        """What the motion of a checked request depends on (`serve/ahead.py`)."""
        return self.intake.motion_key(req, plan)

    def cleanup(self, max_age_s: float | None = None) -> int:
        """Delete request folders older than keep_minutes; returns how many were removed."""
        return self.folders.cleanup(max_age_s)

    def folder(self) -> Path:
        """A new request folder (`request_files.py`): 128 random bits in its name (not guessable by other visitors),
        deleted with the others after keep_minutes."""
        return self.folders.new()

    # ---- checks (serve/intake.py) ----------------------------------------------------------------------
    def check(self, req: Request, need_file: bool = True, extra: list[str] | None = None) -> tuple[Request, Plan]:
        """The upload's presence and size, then every field, all problems at once (`Intake.check`)."""
        return self.intake.check(req, need_file, extra)

    def load(self, req: Request, extra: list[str] | None = None) -> tuple[Request, Plan, np.ndarray]:
        """Checks, then the upload read as 16 kHz speech once per file (`Intake.load`)."""
        return self.intake.load(req, extra)

    def speech(self, req: Request, audio: np.ndarray | None, prog: Progress, extra: list[str] | None = None,
               stream: bool = False) -> tuple[Plan, SpeechInput, list[str]]:
        """Checks, then the speech prepared once for every method, and notes for the page (`Intake.speech`)."""
        return self.intake.speech(req, audio, prog, extra, stream)

    # ---- through the port ------------------------------------------------------------------------------
    def sweep(self, req: SweepRequest, limits: SweepLimits = SweepLimits(), progress: Progress | None = None,
              cancelled: Callable[[], bool] | None = None) -> SweepOutcome:
        """A sweep of methods x steps x CFG x seeds on one upload, through the same checks, speech and request
        folders as a request (`serve/sweep.py`)."""
        return self.generation.sweep(req, limits, progress, cancelled)

    def run(self, req: Request, progress: Progress | None = None, audio: np.ndarray | None = None) -> Result:
        """Serve one request (see the module docstring). `audio` (16 kHz) skips reading req.audio_path."""
        return self.generation.run(req, progress, audio)

    def stream(self, req: Request, progress: Progress | None = None, audio: np.ndarray | None = None,
               previews: bool = True) -> Iterator[Result]:
        """The request's result as each method is made, fastest first, without the video and the downloads
        (`serve/progressive.py`): the page shows every body the moment its motion exists (`previews`: the first
        method's raw windows too). Replicas give one result, once every method is made."""
        return self.generation.stream(req, progress, audio, previews)

    def edit(self, result: Result | None, method: str, start: float | None, end: float | None,
             regions: Sequence[str] | str, seed, progress: Progress | None = None) -> Result:
        """A new result with `method`'s motion of `result` edited (serve/editing.py); `result` is its `previous`."""
        return self.generation.edit(result, method, start, end, regions, seed, progress)

    def render(self, result: Result, progress: Progress | None = None,
               cancelled: Callable[[], bool] | None = None, character=None, owner=None) -> Result:
        """The result with its video: for a request run with `render=False` (the page shows the motions first),
        with the rendering column of the timing rows and `seconds` (request start to video ready) filled in;
        a result that has its video comes back as it is. The video waits for its turn in the server's render queue
        (`serve/renders.py`: `owner`, the page session, has one video in it at a time, a newer one cancels the older);
        progress says its place in the queue, then frame k/n and the time left. `cancelled()` (asked every 0.1 s),
        or the ticket cancelled by `cancel_renders(owner)`, stops it at once, in the queue or rendering:
        RenderCancelled (render/background.py). character: a retarget.Character; one with a mesh is drawn in the video
        instead of the body."""
        return in_turn(self.renders, self.generation.render, result, progress, cancelled, character, owner)

    def cancel_renders(self, owner) -> int:
        """Stop every video of `owner` (a page session that closed or ended): waiting ones leave the queue, a running
        one's process is killed and its slot freed; returns how many."""
        return self.renders.cancel(owner)

    def export(self, result: Result) -> Result:
        """The result with its downloads (the page shows the video first, then calls this); written once: a result
        that has them comes back as it is."""
        return self.generation.export(result)

    def export_each(self, result: Result) -> list[Path]:
        """npz + BVH of each motion of the result (in the page's order), written here once per request and method:
        the downloads of the methods made so far of a result that grows (`stream`); `export` adds the rest."""
        return self.local.export_each(result)


def _warmup_words() -> list:
    return [Word("hello", 0.1, 0.5), Word("there", 0.5, 0.9)]

