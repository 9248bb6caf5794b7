"""What the web app does for one request, without any UI: the app (`app/`), its tests and the user-study
batch mode call this.

    service = GestureService.from_settings(ServiceSettings())           # shipped checkpoints, mannequin
    out = service.run(Request(audio_path="speech.wav", text="what was said",
                              methods=("gesturelsm", "ddim", "ground_truth")))
    out.video, out.rows, out.downloads, out.glb, out.text_mode

One request = load the upload -> prepare the speech once (features, word timings) -> generate per method ->
post-process (stand in place, smoothing) -> render all methods side by side with the speech -> exports ->
one timing row per method and stage. Generation and post-processing are the library's one request flow
(`pipeline.generate_all`, `motion/postprocess.py`); this module adds the upload checks, rendering, exports and
the timing table. Every problem a visitor can fix raises an `errors.GestureError` (`ServiceError` is its old
name here) with a message meant for the page.
"""
from __future__ import annotations

import logging
import os
import secrets
import shutil
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Mapping, Sequence

import numpy as np

from .align import Word
from .app_checks import check_request, textgrid_words
from .asr.source import automatic_words
from .audio import SAMPLE_RATE, AudioTooLongError, load_audio
from .body import load_body_model
from .body.model import resolve_model_path
from .data.lookup import find_beat2_take
from .errors import AudioError, GestureError, InputError, RenderError
from .export import export_bvh, export_glb, export_keypoints, export_npz
from .flows import DEFAULT_STEPS
from .limits import transcript_problems
from .motion.postprocess import DEFAULT_SMOOTHING, SMOOTHING_WINDOWS, fit_length, smooth, stand_in_place
from .motion.sequence import MotionSequence
from .pipeline import ALL_FACTS, GROUND_TRUTH, Generated, GesturePipeline, Plan, SpeechInput
from .render.background import render_apart

Progress = Callable[[float, str], None]

log = logging.getLogger("gesturelsm.app")
METHOD_LABELS = {**{k: f.label for k, f in ALL_FACTS.items()}, GROUND_TRUTH: "Ground truth"}
VIDEO_SIZES = (256, 384, 512, 640)
TIMING_COLUMNS = ["method", "features", "alignment", "transcription", "sampling", "decoding", "rendering", "generation",
                  "real-time factor"]                   # seconds, except the real-time factor


ServiceError = GestureError      # alias: a problem with the request that the visitor can fix

@dataclass(frozen=True)
class ServiceSettings:
    checkpoints: str | None = None          # folder with tokenizer/ and generator/ (default: shipped assets/)
    body_model: str | None = None           # SMPL-X .npz (default: $GESTURELSM_SMPLX_MODEL or the mannequin)
    beat2: str | None = None                # BEAT2-layout folder: ground truth for known takes
    workdir: str | None = None              # where outputs go (default: <tmp>/gesturelsm-app)
    max_seconds: float = 300.0              # longest speech accepted
    max_upload_mb: float = 50.0             # largest upload accepted
    keep_minutes: float = 60.0              # outputs older than this are deleted
    concurrency: int = 1                    # requests generated at the same time (the rest queue)
    max_steps: int = 32                     # the page's steps slider stops here (and at the methods' max_steps)
    max_ddim_steps: int = 100               # the page's DDIM steps slider stops here
    render_nice: int = 19                   # the mp4 renders in a process of its own this much niced (render/background.py)


@dataclass
class Request:
    audio_path: str | None
    text: str = ""
    textgrid_path: str | None = None
    methods: Sequence[str] = ("gesturelsm",)
    steps: Mapping[str, int] | int = field(default_factory=lambda: dict(DEFAULT_STEPS))   # per method; an int:
    cfg: float = 2.0                                                                      # the same for all
    seed: int = 0
    stand_in_place: bool = False
    smoothing: str = DEFAULT_SMOOTHING
    size: int = 384
    exports: bool = True
    transcribe: bool = True                  # automatic transcript when neither text nor TextGrid is given
    render: bool = True                      # False: motions only (the page's player); GestureService.render later

    def plan(self, beat2: str | None = None) -> Plan:
        steps = self.steps if isinstance(self.steps, Mapping) else {k: int(self.steps) for k in ALL_FACTS}
        return Plan(list(dict.fromkeys(self.methods or ())), dict(steps), float(self.cfg), int(self.seed),
                    bool(self.stand_in_place), str(self.smoothing), beat2,
                    Path(self.audio_path).name if self.audio_path else None)


@dataclass
class Outcome:
    video: Path | None                       # None until rendered (Request.render=False, then .render())
    rows: list[list]                         # TIMING_COLUMNS per method, then a total row
    downloads: list[Path]
    glb: Path | None
    text_mode: str
    warnings: list[str]
    ground_truth: str | None                 # the BEAT2 take recognised, if any
    seconds: float                           # request start to video ready
    timings: dict[str, dict[str, float]] = field(default_factory=dict)
    motions: dict[str, MotionSequence] = field(default_factory=dict, repr=False)   # shown, post-processed
    transcript: str | None = None            # the automatic transcript used (shown in the transcript box)
    labels: list[str] = field(default_factory=list)          # one per shown motion, as drawn in the video
    audio: np.ndarray | None = field(default=None, repr=False)  # the speech, 16 kHz mono
    render_args: dict = field(default_factory=dict, repr=False)  # size, gen_seconds, folder for a later render
    motion_seconds: float = 0.0              # request start to motions ready
    started: float = 0.0                     # time.perf_counter() at the request start

    @property
    def summary(self) -> str:
        lines = [f"**Transcript:** {self.text_mode}", f"**Motion ready in {self.motion_seconds:.1f} s.** " +
                 (f"**Video ready in {self.seconds:.1f} s.**" if self.video else "Rendering the video (mp4)...")]
        if self.ground_truth:
            lines.append(f"**Ground truth:** BEAT2 take `{self.ground_truth}`")
        lines += [f"Note: {w}" for w in self.warnings]
        return "\n\n".join(lines)


# ---- the service -------------------------------------------------------------------------------------------
class GestureService:
    def __init__(self, pipeline, settings: ServiceSettings = ServiceSettings(), body=None):
        self.pipeline = pipeline
        self.settings = settings
        self.body = body
        self.workdir = Path(settings.workdir or Path(tempfile.gettempdir()) / "gesturelsm-app")
        self.workdir.mkdir(parents=True, exist_ok=True)

    @classmethod
    def from_settings(cls, settings: ServiceSettings = ServiceSettings()) -> "GestureService":
        pipe = GesturePipeline.from_pretrained(settings.checkpoints, max_seconds=settings.max_seconds)
        body = load_body_model(str(resolve_model_path(settings.body_model)))
        return cls(pipe, settings, body)

    @property
    def methods(self) -> list[str]:
        """Choices for the page: the loaded generators, then ground truth when a BEAT2 folder is set."""
        order = {m: i for i, m in enumerate(METHOD_LABELS)}
        gens = sorted(self.pipeline.methods, key=lambda m: order.get(m, len(order)))
        return gens + (["ground_truth"] if self.settings.beat2 else [])

    # ---- housekeeping ----------------------------------------------------------------------------------
    def warmup(self) -> float:
        """Load the text encoder and the speech recogniser and run each generator and the recogniser once on 1 s
        of a tone, so the first visitor does not wait for them (without it the first request for 10 s of speech took
        2.02 s on the server against 1.41-1.61 s for later ones); returns the seconds it took."""
        t0 = time.perf_counter()
        y = (0.3 * np.sin(np.arange(SAMPLE_RATE) / SAMPLE_RATE * 2 * np.pi * 180)).astype(np.float32)
        speech = self.pipeline.prepare_speech(y, SAMPLE_RATE, words=_warmup_words())
        for m in self.pipeline.methods:
            self.pipeline.generate(speech, steps=1, method=m)
        automatic_words(y, remember=False)                   # says "unavailable" itself when not installed
        return time.perf_counter() - t0

    def prefetch(self, audio_path: str | None) -> bool:
        """Transcribe an upload before the visitor asks for it (the page calls this when speech is uploaded or
        recorded), so that a request without a transcript finds the words ready (asr.source remembers them). Never
        raises: a file that cannot be used is left for the request to refuse with its message. Returns whether
        the words are ready."""
        if not audio_path:
            return False
        try:
            self._check(Request(audio_path))
            audio = load_audio(audio_path, max_seconds=self.settings.max_seconds)
            self.pipeline.prefetch_transcript(audio, SAMPLE_RATE)
            return True
        except GestureError as exc:                      # the request refuses it with this message
            log.info("no transcript prefetched for %s: %s", Path(audio_path).name, " | ".join(str(exc).splitlines()))
            return False
        except Exception:                                # a bug: keep its traceback in the log, not on the page
            log.exception("prefetching the transcript of %s failed", Path(audio_path).name)
            return False

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
    def _check(self, req: Request, need_file: bool = True) -> tuple[Request, Plan]:
        """The upload's presence and size, then every field (`gesturelsm.limits`): all problems at once, one line
        each, before any work; returns the request with normalised values and its plan (whose generation settings
        the pipeline checks against the method registry)."""
        if need_file:
            if not req.audio_path or not isinstance(req.audio_path, (str, os.PathLike)):
                raise ServiceError("Please record or upload speech first (any common audio format).")
            p = Path(req.audio_path)
            if not p.is_file():
                raise ServiceError("The uploaded audio file is missing on the server; please upload it again.")
            mb = p.stat().st_size / 2 ** 20
            if mb > self.settings.max_upload_mb:
                raise ServiceError(f"The audio file is {mb:.0f} MB; the limit is {self.settings.max_upload_mb:.0f} MB.")
        req, problems = check_request(req, self.methods, self.settings, SMOOTHING_WINDOWS, VIDEO_SIZES, ALL_FACTS)
        if problems:
            raise ServiceError("\n".join(problems))
        plan = req.plan(self.settings.beat2)
        self.pipeline.check_plan(plan)
        return req, plan

    def _words(self, req: Request, seconds: float) -> tuple[list | None, list[str]]:
        """Word timings of the uploaded TextGrid (None without one) and notes for the page, bounded by the
        speech's length (`gesturelsm.app_checks.textgrid_words`)."""
        if not req.textgrid_path:
            return None, []
        words, problems, notes = textgrid_words(req.textgrid_path, seconds)
        if problems:
            raise ServiceError("\n".join(problems))
        return words, notes

    def _speech(self, req: Request, audio: np.ndarray | None, prog: Progress) -> tuple[Plan, SpeechInput, list[str]]:
        """Checks, then the speech prepared once for every method, and notes for the page."""
        if audio is None:
            req, plan = self._check(req)
            try:
                audio = load_audio(req.audio_path, max_seconds=self.settings.max_seconds)
            except AudioTooLongError as exc:
                raise AudioError(f"The audio is too long: {exc}") from None
            except AudioError as exc:
                raise AudioError(f"The audio could not be read: {exc}") from None
        else:
            req, plan = self._check(req, need_file=False)
        seconds = len(audio) / SAMPLE_RATE
        problems = transcript_problems(req.text, seconds)
        if problems:
            raise ServiceError("\n".join(problems))
        words, notes = self._words(req, seconds)
        prog(0.02, "reading speech")
        speech = self.pipeline.prepare_speech(audio, SAMPLE_RATE, words=words, text=req.text or None,
                                              progress=lambda f, m: prog(0.02 + 0.1 * f, m),
                                              transcribe=bool(req.transcribe))
        return plan, speech, notes

    # ---- one request -----------------------------------------------------------------------------------
    def run(self, req: Request, progress: Progress | None = None, audio: np.ndarray | None = None) -> Outcome:
        """Serve one request (see the module docstring). `audio` (16 kHz) skips reading req.audio_path."""
        t_start = time.perf_counter()
        prog = progress or (lambda f, m: None)
        self.cleanup()
        plan, speech, notes = self._speech(req, audio, prog)
        out = self.workdir / f"req-{secrets.token_hex(16)}"    # 128 random bits: not guessable by other visitors
        out.mkdir(parents=True)
        gen = self.pipeline.generate_all(speech, plan, progress=lambda f, m: prog(0.12 + 0.5 * f, m))
        gen.warnings.extend(notes)
        if not gen.motions:
            raise ServiceError("Nothing to show: choose a generator method.")
        labels = [f"{METHOD_LABELS.get(m, m)} {r.steps} steps CFG {plan.cfg:g}" for m, r in gen.results.items()]
        labels += ["Ground truth (BEAT2)"] * (GROUND_TRUTH in gen.motions)
        gen_s = [r.generation_seconds for r in gen.results.values()] + [None] * (GROUND_TRUTH in gen.motions)
        motion_s = time.perf_counter() - t_start
        render_args = {"size": int(req.size), "gen_seconds": gen_s, "folder": out}
        video, render_s = None, 0.0
        if req.render:
            video, render_s = self._render(list(gen.motions.values()), labels, speech.audio, render_args, prog)
        ready = time.perf_counter() - t_start
        timings = {m: dict(r.timings) for m, r in gen.results.items()}
        rows = timing_rows(gen, timings, speech.duration, render_s, ready)
        outcome = Outcome(video, rows, [], None, speech.text_mode, gen.warnings, gen.ground_truth, ready, timings,
                          dict(gen.motions), speech.transcript, labels, speech.audio, render_args, motion_s, t_start)
        if req.exports:
            prog(0.93, "exports")
            self.export(outcome)
        prog(1.0, "done")
        return outcome

    def _render(self, motions, labels, audio, args: dict, prog: Progress,
                cancelled: Callable[[], bool] | None = None) -> tuple[Path, float]:
        prog(0.62, "rendering video")
        t_r = time.perf_counter()
        video = Path(args["folder"]) / "gestures.mp4"
        # the render process loads the body itself: hand it the file (None: it resolves the default as we would)
        body_path = (self.body.path if hasattr(self.body, "path")
                     else None if self.body is None else resolve_model_path(self.body))
        try:
            render_apart(motions, audio, video, labels=labels, size=(args["size"], args["size"]),
                         body_path=body_path, gen_seconds=args["gen_seconds"],
                         progress=lambda f, msg: prog(0.62 + 0.3 * f, f"rendering: {msg}"),
                         nice=self.settings.render_nice, cancelled=cancelled)
        except RenderError as exc:
            raise RenderError(f"Rendering failed on the server: {exc}") from None
        return video, time.perf_counter() - t_r

    def render(self, outcome: Outcome, progress: Progress | None = None,
               cancelled: Callable[[], bool] | None = None) -> Outcome:
        """Render the video of a request run with `render=False` (the page shows the motions first); fills
        the rendering column of the timing rows and `seconds` (request start to video ready). `cancelled()` (asked
        every ~1 % of the frames) stops it: RenderCancelled, outcome unchanged (render/background.py)."""
        if outcome.video is None and outcome.motions:
            motions = list(outcome.motions.values())
            outcome.video, render_s = self._render(motions, outcome.labels, outcome.audio, outcome.render_args,
                                                   progress or (lambda f, m: None), cancelled)
            col = TIMING_COLUMNS.index("rendering")
            for row in outcome.rows[:-1]:
                row[col] = round(render_s / len(motions), 3)
            outcome.seconds = time.perf_counter() - outcome.started
            speech_s = len(outcome.audio) / SAMPLE_RATE if outcome.audio is not None else 0.0
            outcome.rows[-1][col:col + 3] = [round(render_s, 3), round(outcome.seconds, 3),
                                             round(speech_s / max(outcome.seconds, 1e-9), 2)]
        return outcome

    def export(self, outcome: Outcome) -> Outcome:
        """Write the downloads of a finished request (the page shows the video first, then calls this)."""
        motions = outcome.motions
        if motions and not outcome.downloads:
            folder = Path(outcome.render_args.get("folder") or outcome.video.parent)
            outcome.downloads, outcome.glb = self._exports(list(motions.values()), list(motions), folder)
        return outcome

    def _exports(self, motions: list[MotionSequence], names: list[str], out: Path) -> tuple[list[Path], Path | None]:
        """npz + BVH per method, GLB + keypoints for the first one (the interactive view shows that GLB)."""
        files: list[Path] = []
        glb = None
        for i, (seq, name) in enumerate(zip(motions, names)):
            files.append(export_npz(seq, out / f"{name}.npz"))
            files.append(export_bvh(seq, out / f"{name}.bvh", body=self.body))
            if i == 0:
                glb = export_glb(seq, out / f"{name}.glb", body=self.body)
                files.append(glb)
                files.append(export_keypoints(seq, out / f"{name}_keypoints.json", body=self.body))
        return [Path(f) for f in files], glb


def timing_rows(gen: Generated, timings: dict[str, dict[str, float]], duration: float, render_s: float,
                ready: float) -> list[list]:
    """TIMING_COLUMNS per generator (rendering shared evenly by the shown motions), ground truth, then the whole
    request. Adds each generator's share of the rendering to `timings`."""
    rows = []
    n = len(gen.motions)
    for m in gen.results:
        t = timings[m]
        t["rendering"] = render_s / n
        g = sum(v for k, v in t.items() if k not in ("alignment", "transcription", "rendering"))
        rows.append([METHOD_LABELS[m], *(round(t.get(k, 0.0), 3) for k in
                                          ("features", "alignment", "transcription", "sampling", "decoding",
                                           "rendering")),
                     round(g, 3), round(duration / max(g, 1e-9), 1)])
    if gen.ground_truth:
        rows.append(["Ground truth", 0.0, 0.0, 0.0, 0.0, 0.0, round(render_s / n, 3), 0.0, None])
    rows.append([f"whole request, {duration:.1f} s of speech", None, None, None, None, None,
                 round(render_s, 3), round(ready, 3), round(duration / max(ready, 1e-9), 2)])
    return rows


def _warmup_words() -> list:
    return [Word("hello", 0.1, 0.5), Word("there", 0.5, 0.9)]


def duration_seconds(path: str | os.PathLike) -> float:
    """Seconds of audio in a file (for limits shown before the work starts)."""
    return len(load_audio(path)) / SAMPLE_RATE


__all__ = ["GestureService", "Outcome", "Request", "ServiceError", "ServiceSettings", "METHOD_LABELS",
           "DEFAULT_SMOOTHING", "SMOOTHING_WINDOWS", "TIMING_COLUMNS", "VIDEO_SIZES", "find_beat2_take", "fit_length",
           "smooth", "stand_in_place", "timing_rows", "InputError"]
