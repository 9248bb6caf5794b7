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
the result after each method (`serve/progressive.py`); this module adds the upload checks, rendering, exports and
the timing table. A request run with `render=False` returns its `Result` at once; `render(result)` and
`export(result)` then return new results with the video and the downloads (`serve/request.py`). Every problem a
visitor can fix raises an `errors.GestureError` with a message meant for the page.
"""
from __future__ import annotations

import logging
import os
import secrets
import shutil
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Callable, Iterator

import numpy as np
import torch

from ..align import Word
from ..asr.source import warm_up as warm_words
from ..audio import SAMPLE_RATE, AudioTooLongError, load_audio
from ..body import load_body_model
from ..body.model import resolve_model_path
from ..constants import Progress
from ..errors import AudioError, CancelToken, GestureError, InputError, RenderError
from ..evaluation.sweep import SweepLimits
from ..export import export_arkit, export_bvh, export_glb, export_keypoints, export_npz
from ..motion.sequence import MotionSequence
from ..backends import GROUND_TRUTH, SPECS, checkpoint_sources
from ..pipeline import GesturePipeline, Plan, SpeechInput
from ..progress import REQUEST
from ..settings import DEFAULTS, Limits
from ..render.background import render_apart
from .checks import check_request, textgrid_words
from .ahead import Ahead, motion_key
from .editing import edit_result
from .limits import transcript_problems
from .config import ServiceSettings
from .prepared import PreparedUploads, file_key
from .progressive import SPEECH_AHEAD, stream_request
from .renders import RenderQueue, video_progress, waiting_line
from .request import VIDEO_SIZES, Request, Result, result_rows, with_render_time
from .sweep import SweepOutcome, SweepRequest, run_sweep_request

log = logging.getLogger("gesturelsm.app")
WARMUP_SECONDS = (1, 4, 8, 15, 30, 60)      # speech lengths the warm-up generates for: 1-16 windows (kernel shapes)


# ---- the service -------------------------------------------------------------------------------------------
class GestureService:
    def __init__(self, pipeline, settings: ServiceSettings = ServiceSettings(), body=None):
        self.pipeline = pipeline
        self.settings = settings
        self.body = body
        self.workdir = Path(settings.workdir or Path(tempfile.gettempdir()) / "gesturelsm-app")
        self.workdir.mkdir(parents=True, exist_ok=True)
        self.uploads = PreparedUploads()            # uploads decoded and prepared before the click (prefetch)
        self.ahead = Ahead()                        # motion made before the click for the page's settings (prefetch)
        self.renders = RenderQueue(settings.concurrency)   # videos: this many at once, the rest wait (serve/renders.py)

    @classmethod
    def from_settings(cls, settings: ServiceSettings = ServiceSettings()) -> "GestureService":
        pipe = GesturePipeline.from_pretrained(checkpoints=checkpoint_sources(settings.checkpoints),
                                               max_seconds=settings.max_seconds)
        body = load_body_model(str(resolve_model_path(settings.body_model)))
        return cls(pipe, settings, body)

    @property
    def limits(self) -> Limits:
        """What this server accepts beyond each method's own bounds: speech length, and the sliders' ends as step caps
        for every request (Generate, Sweep, the API)."""
        st = self.settings
        return Limits(st.max_seconds, {"steps": st.max_steps, "ddim_steps": st.max_ddim_steps})

    @property
    def methods(self) -> list[str]:
        """Choices for the page: the loaded generators in registry order, then ground truth when a BEAT2 folder is
        set."""
        order = {m: i for i, m in enumerate(SPECS)}
        gens = sorted(self.pipeline.methods, key=lambda m: order.get(m, len(order)))
        return gens + ([GROUND_TRUTH] if self.settings.beat2 else [])

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
        if not audio_path:
            return False
        try:
            self.speech(Request(audio_path, text=text or "", textgrid_path=textgrid_path, transcribe=transcribe,
                                language=ahead.language if ahead is not None else DEFAULTS.language),
                         None, lambda f, m: None, stream=True)     # the motion made ahead joins the words as they come
        except GestureError as exc:                      # the request refuses it with this message
            log.info("upload not prepared %s: %s", Path(audio_path).name, " | ".join(str(exc).splitlines()))
            return False
        except Exception:                                # a bug: keep its traceback in the log, not on the page
            log.exception("preparing the upload %s failed", Path(audio_path).name)
            return False
        if ahead is not None:
            try:
                self.make_ahead(ahead)
            except GestureError as exc:                  # settings the click would refuse: nothing made ahead
                log.info("no motion made ahead: %s", " | ".join(str(exc).splitlines()))
            except Exception:
                log.exception("making motion ahead failed")
        return True

    def make_ahead(self, req: Request):
        """Start making `req`'s motion in the background (`serve/ahead.py`); the run, or None where none is started
        (the server is busy, or such a run exists; or the server is set not to: `ServiceSettings.ahead`). Raises the
        request's GestureError when it would be refused."""
        if not self.settings.ahead:
            return None
        req, plan = self.check(req)

        def make(run):
            torch.set_num_threads(self.settings.threads)
            _, speech, _ = self.speech(req, None, lambda f, m: None, stream=True)   # prepared by the prefetch
            return self.pipeline.generate_each(speech, plan, progress=run.check, body=self.body, keep_going=True)
        return self.ahead.start(self.motion_key(req, plan), make, ", ".join(plan.methods))

    def motion_key(self, req: Request, plan: Plan):
        """What the motion of a checked request depends on (`serve/ahead.py`)."""
        return motion_key(file_key(req.audio_path), self._speech_key(req, plan), plan)

    @staticmethod
    def _speech_key(req: Request, plan: Plan) -> tuple:
        """The transcript settings an upload's speech is prepared for."""
        return ((req.text or "").strip(), file_key(req.textgrid_path), plan.settings.transcribe, plan.settings.language)

    def cleanup(self, max_age_s: float | None = None) -> int:
        """Delete request folders older than keep_minutes; returns how many were removed."""
        age = self.settings.keep_minutes * 60 if max_age_s is None else max_age_s
        now, removed = time.time(), 0
        for d in self.workdir.glob("req-*"):
            try:
                if now - d.stat().st_mtime > age:
                    shutil.rmtree(d, ignore_errors=True)
                    removed += 1
            except FileNotFoundError:
                continue
        return removed

    # ---- checks ----------------------------------------------------------------------------------------
    def _upload(self, audio_path) -> list[str]:
        """The upload is there and within the size limit: [] or the problem."""
        if not audio_path or not isinstance(audio_path, (str, os.PathLike)):
            return ["Please record or upload speech first (any common audio format)."]
        p = Path(audio_path)
        if not p.is_file():
            return ["The uploaded audio file is missing on the server; please upload it again."]
        mb = p.stat().st_size / 2 ** 20
        if mb > self.settings.max_upload_mb:
            return [f"The audio file is {mb:.0f} MB; the limit is {self.settings.max_upload_mb:.0f} MB."]
        return []

    def check(self, req: Request, need_file: bool = True, extra: list[str] | None = None) -> tuple[Request, Plan]:
        """The upload's presence and size, then every field (the settings' validator, `gesturelsm.settings`, with this
        server's limits): all problems at once (with `extra` ones found by the caller), one line each, before any
        work; returns the request with normalised values and its plan."""
        upload = self._upload(req.audio_path) if need_file else []
        req, settings, problems = check_request(req, self.methods, self.limits, VIDEO_SIZES)
        problems = upload + problems + (extra or [])
        if problems:
            raise InputError("\n".join(problems))
        name = Path(req.audio_path).name if req.audio_path else None
        return req, Plan(settings, self.settings.beat2, name)

    def _words(self, req: Request, seconds: float) -> tuple[list | None, list[str]]:
        """Word timings of the uploaded TextGrid (None without one) and notes for the page, bounded by the
        speech's length (`gesturelsm.serve.checks.textgrid_words`)."""
        if not req.textgrid_path:
            return None, []
        words, problems, notes = textgrid_words(req.textgrid_path, seconds)
        if problems:
            raise InputError("\n".join(problems))
        return words, notes

    def load(self, req: Request, extra: list[str] | None = None) -> tuple[Request, Plan, np.ndarray]:
        """Checks (`check`), then the upload read as 16 kHz speech within the server's length limit, once per file
        (`serve/prepared.py`: an upload's prefetch has usually read it)."""
        req, plan = self.check(req, extra=extra)
        path = req.audio_path
        return req, plan, self.uploads.decoded(path, lambda: self._read(path))

    def _read(self, path: str) -> np.ndarray:
        try:
            return load_audio(path, max_seconds=self.settings.max_seconds)
        except AudioTooLongError as exc:
            raise AudioError(f"The audio is too long: {exc}") from None
        except AudioError as exc:
            raise AudioError(f"The audio could not be read: {exc}") from None

    def speech(self, req: Request, audio: np.ndarray | None, prog: Progress, extra: list[str] | None = None,
               stream: bool = False) -> tuple[Plan, SpeechInput, list[str]]:
        """Checks (`check`), then the speech prepared once for every method (the transcript typed, from the TextGrid,
        recognised or none, as the request says), and notes for the page; for an upload, what its prefetch prepared
        (`serve/prepared.py`), else prepared here and remembered. Automatic words are recognised on a thread: with
        `stream` the speech may come back before them (generation joins them), else once known (`prog`: its 0..1)."""
        path = None
        if audio is None:
            req, plan, audio = self.load(req, extra)
            path = req.audio_path
        else:
            req, plan = self.check(req, need_file=False, extra=extra)
        seconds = len(audio) / SAMPLE_RATE
        problems = transcript_problems(req.text, seconds)
        if problems:
            raise InputError("\n".join(problems))

        fresh = []

        def prepare() -> tuple[SpeechInput, list[str]]:
            fresh.append(True)
            words, notes = self._words(req, seconds)
            prog(0.0, "reading speech")
            live = [True]                                # the words' thread says nothing once this returns
            speech = self.pipeline.prepare_speech(audio, SAMPLE_RATE, words=words, text=req.text or None,
                                                  progress=lambda f, m: live[0] and prog(f, m),
                                                  transcribe=plan.settings.transcribe,
                                                  language=plan.settings.language, stream=True)
            live[0] = False
            return speech, notes
        speech, notes = prepare() if path is None else self.uploads.prepared(path, self._speech_key(req, plan), prepare)
        if path is not None and not fresh:  # prepared at the upload: its stages' times are the ones spent then, said so
            notes = [*notes, SPEECH_AHEAD]
        return plan, speech if stream else self.pipeline.settled(speech), notes

    def sweep(self, req: SweepRequest, limits: SweepLimits = SweepLimits(), progress: Progress | None = None,
              cancelled: Callable[[], bool] | None = None) -> SweepOutcome:
        """A sweep of methods x steps x CFG x seeds on one upload, through the same checks, speech and request
        folders as a request (`serve/sweep.py`)."""
        self.ahead.cancel()
        with self.ahead.generating():
            return run_sweep_request(self, req, limits, progress, cancelled)

    # ---- one request -----------------------------------------------------------------------------------
    def run(self, req: Request, progress: Progress | None = None, audio: np.ndarray | None = None) -> Result:
        """Serve one request (see the module docstring). `audio` (16 kHz) skips reading req.audio_path."""
        prog = progress or (lambda f, m: None)
        for result in stream_request(self, req, prog, audio):
            pass
        if req.render:
            result = self.render(result, prog)
        if req.exports:
            prog(REQUEST.at("exports"), "exports")
            result = self.export(result)
        prog(1.0, "done")
        return result

    def stream(self, req: Request, progress: Progress | None = None, audio: np.ndarray | None = None,
               previews: bool = True) -> Iterator[Result]:
        """The request's result as each method is made, fastest first, without the video and the downloads
        (`serve/progressive.py`): the page shows every body the moment its motion exists (`previews`: the first
        method's raw windows too). A service that makes its results elsewhere (a subclass with its own `run` and no
        `stream` of its own: the replicas' front end) gives one result, once `run` has made every method."""
        if type(self).run is not GestureService.run and type(self).stream is GestureService.stream:
            return iter([self.run(req, progress, audio)])
        return stream_request(self, req, progress, audio, previews)

    def edit(self, result: Result | None, method: str, start: float | None, end: float | None, regions, seed,
             progress: Progress | None = None) -> Result:
        """A new result with `method`'s motion of `result` edited (serve/editing.py); `result` is its `previous`."""
        self.ahead.cancel()
        with self.ahead.generating():
            out = edit_result(self.pipeline, result, method, start, end, regions, seed, progress, self.body)
        return replace(out, rows=result_rows(out))

    def folder(self) -> Path:
        """A new request folder: 128 random bits in its name (not guessable by other visitors), deleted with the
        others after keep_minutes."""
        out = self.workdir / f"req-{secrets.token_hex(16)}"
        out.mkdir(parents=True)
        return out

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
        if result.video is not None or not result.motions:
            return result
        prog = progress or (lambda f, m: None)
        with self.renders.enter(owner) as ticket:
            ticket.wait(lambda position: prog(REQUEST.at("video"), waiting_line(position)), cancelled)
            t_r = time.perf_counter()
            out = self._video(result, video_progress(REQUEST.span(prog, "video")),
                              CancelToken(ticket.cancelled, cancelled), character)
            render_s = time.perf_counter() - t_r
        return with_render_time(out, render_s, time.perf_counter() - result.job.started)

    def cancel_renders(self, owner) -> int:
        """Stop every video of `owner` (a page session that closed or ended): waiting ones leave the queue, a running
        one's process is killed and its slot freed; returns how many."""
        return self.renders.cancel(owner)

    def _video(self, result: Result, progress: Progress, cancelled: Callable[[], bool], character) -> Result:
        """The result with its video rendered here (a process of its own, niced: render/background.py)."""
        job = result.job
        video = job.folder / "gestures.mp4"
        # the render process loads the body itself: hand it the file (None: it resolves the default as we would)
        body_path = (self.body.path if hasattr(self.body, "path")
                     else None if self.body is None else resolve_model_path(self.body))
        try:
            render_apart(list(job.motions), job.audio, video, labels=list(job.labels), size=(job.size, job.size),
                         body_path=body_path, gen_seconds=list(job.gen_seconds), progress=progress,
                         nice=self.settings.render_nice, cancelled=cancelled,
                         rig=character.path if character is not None and character.document is not None else None,
                         grounding=job.grounding)
        except RenderError as exc:
            raise RenderError(f"Rendering failed on the server: {exc}") from None
        return replace(result, video=video)

    def export(self, result: Result) -> Result:
        """The result with its downloads (the page shows the video first, then calls this); written once: a result
        that has them comes back as it is."""
        if not result.motions or result.downloads:
            return result
        files, glb = self._exports(list(result.motions.values()), list(result.motions), result.job.folder)
        return replace(result, downloads=tuple(files), glb=glb)

    def export_each(self, result: Result) -> list[Path]:
        """npz + BVH of each motion of the result (in the page's order), written once per request and method: the
        downloads of the methods made so far of a result that grows (`stream`); `export` adds the rest."""
        return [p for seq, name in zip(result.motions.values(), result.motions)
                for p in self._method_files(seq, name, result.job.folder)]

    def _method_files(self, seq: MotionSequence, name: str, out: Path) -> list[Path]:
        """NAME.npz and NAME.bvh in `out`, each written whole under another name first (the page's downloads event
        and the exports after the video may make the same file at once; a file that exists is complete)."""
        files = []
        for path, write in ((out / f"{name}.npz", lambda p: export_npz(seq, p)),
                            (out / f"{name}.bvh", lambda p: export_bvh(seq, p, body=self.body))):
            if not path.exists():
                tmp = path.with_name(f".{secrets.token_hex(8)}{path.suffix}")
                write(tmp)
                os.replace(tmp, path)
            files.append(path)
        return files

    def _exports(self, motions: list[MotionSequence], names: list[str], out: Path) -> tuple[list[Path], Path | None]:
        """npz + BVH per method (`export_each`); GLB, keypoints and the ARKit face (Live Link Face CSV) for the first
        one (the interactive view shows that GLB)."""
        files: list[Path] = []
        glb = None
        for i, (seq, name) in enumerate(zip(motions, names)):
            files += self._method_files(seq, name, out)
            if i == 0:
                glb = export_glb(seq, out / f"{name}.glb", body=self.body)
                files.append(glb)
                files.append(export_keypoints(seq, out / f"{name}_keypoints.json", body=self.body))
                files.append(export_arkit(seq, out / f"{name}_arkit.csv", body=self.body))
        return [Path(f) for f in files], glb


def _warmup_words() -> list:
    return [Word("hello", 0.1, 0.5), Word("there", 0.5, 0.9)]
