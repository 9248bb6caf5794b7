"""What the web app does for one request, without any UI: the app (`app/`), its tests and the user-study
batch mode call this.

    service = GestureService.from_settings(ServiceSettings())           # shipped checkpoints, mannequin
    out = service.run(Request(audio_path="speech.wav", text="what was said",
                              methods=("gesturelsm", "ddim", "ground_truth")))
    out.video, out.rows, out.downloads, out.glb, out.text_mode

One request = load the upload -> prepare the speech once (features, word timings) -> generate per method ->
post-process (stand in place, smoothing) -> render all methods side by side with the speech -> exports ->
one timing row per method and stage. Every problem a visitor can fix raises `ServiceError` with a message
meant for the page.

Post-processing (both optional, applied to every shown motion, ground truth included):
- stand in place: the root's horizontal translation (x, z) is set to 0 on every frame; height (y) is kept.
- smoothing: a Savitzky-Golay filter (polynomial order 2) along time on the 6D rotation features of all
  joints (re-orthonormalised when decoded back to axis-angle), window 5 / 9 / 15 frames for
  light / medium / strong (0.17 / 0.3 / 0.5 s at 30 fps); root height and expressions are filtered too.
"""
from __future__ import annotations

import os
import shutil
import tempfile
import time
import uuid
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from .audio import SAMPLE_RATE, AudioError, load_audio
from .motion.sequence import MotionSequence

Progress = Callable[[float, str], None]

METHOD_LABELS = {"gesturelsm": "GestureLSM", "rectified_flow": "Rectified flow", "ddim": "DDIM",
                 "ground_truth": "Ground truth"}
SMOOTHING_WINDOWS = {"off": 0, "light": 5, "medium": 9, "strong": 15}
VIDEO_SIZES = (256, 384, 512, 640)
TIMING_COLUMNS = ["method", "features", "alignment", "sampling", "decoding", "rendering", "generation",
                  "real-time factor"]                   # seconds, except the real-time factor


class ServiceError(ValueError):
    """A problem with the request that the visitor can fix; the message is shown on the page."""


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
    max_steps: int = 32                     # slider range in the page


@dataclass
class Request:
    audio_path: str | None
    text: str = ""
    textgrid_path: str | None = None
    methods: Sequence[str] = ("gesturelsm",)
    steps: int = 8
    cfg: float = 2.0
    seed: int = 0
    ddim_steps: int = 20
    stand_in_place: bool = False
    smoothing: str = "off"
    size: int = 384
    exports: bool = True
    render: bool = True                     # False: motions only (the page's player); GestureService.render later


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


# ---- post-processing ------------------------------------------------------------------------------------
def stand_in_place(seq: MotionSequence) -> MotionSequence:
    """Zero the root's horizontal (x, z) translation on every frame; keep its height."""
    trans = seq.trans.copy()
    trans[:, [0, 2]] = 0.0
    return replace(seq, trans=trans)


def smooth(seq: MotionSequence, strength: str = "medium") -> MotionSequence:
    """Savitzky-Golay (order 2) along time on the 6D rotations, root height and expressions."""
    from scipy.signal import savgol_filter

    from .motion.rotations import axis_angle_to_rot6d, rot6d_to_axis_angle
    import torch

    if strength not in SMOOTHING_WINDOWS:
        raise ServiceError(f"smoothing must be one of {', '.join(SMOOTHING_WINDOWS)} (got {strength!r})")
    win = SMOOTHING_WINDOWS[strength]
    T = seq.num_frames
    if win == 0 or T < 4:
        return seq
    win = min(win, T if T % 2 else T - 1)
    poly = min(2, win - 1)
    r6 = axis_angle_to_rot6d(torch.from_numpy(seq.poses.reshape(T, -1, 3))).numpy()      # (T, 55, 6)
    r6 = savgol_filter(r6, win, poly, axis=0)
    poses = rot6d_to_axis_angle(torch.from_numpy(np.ascontiguousarray(r6, np.float32))).numpy().reshape(T, -1)
    trans = seq.trans.copy()
    trans[:, 1] = savgol_filter(trans[:, 1], win, poly)
    expr = savgol_filter(seq.expressions, win, poly, axis=0)
    return replace(seq, poses=poses, trans=trans, expressions=expr)


def fit_length(seq: MotionSequence, num_frames: int) -> MotionSequence:
    """Trim, or hold the last frame, so a motion lasts exactly num_frames."""
    if seq.num_frames >= num_frames:
        return seq.slice(0, num_frames)
    pad = num_frames - seq.num_frames
    rep = lambda a: np.concatenate([a, np.repeat(a[-1:], pad, axis=0)])  # noqa: E731
    return replace(seq, poses=rep(seq.poses), trans=rep(seq.trans), expressions=rep(seq.expressions))


# ---- ground truth for known BEAT2 takes --------------------------------------------------------------------
def find_beat2_take(root: str | Path | None, audio: np.ndarray, filename: str | None = None) -> str | None:
    """Name of the BEAT2 take whose speech the upload is (same file name, or same length and samples)."""
    if not root:
        return None
    import soundfile as sf

    from .data.beat2 import Beat2Dataset, DatasetError

    try:
        ds = Beat2Dataset(root)
    except DatasetError:
        return None
    stem = Path(filename).stem if filename else None
    if stem and stem in ds.names:
        return stem
    n = len(audio)
    for name in ds.names:
        wav = ds.wave_dir / f"{name}.wav"
        if not wav.exists():
            continue
        try:
            info = sf.info(str(wav))
        except Exception:
            continue
        if abs(info.frames / info.samplerate - n / SAMPLE_RATE) > 0.05:
            continue
        ref = load_audio(wav)
        k = min(len(ref), n, SAMPLE_RATE * 5)
        a, b = audio[:k], ref[:k]
        if k > 0 and np.corrcoef(a, b)[0, 1] > 0.98:
            return name
    return None


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
        from .body import load_body_model
        from .body.model import resolve_model_path
        from .pipeline import GesturePipeline

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
        """Load the text encoder and run each generator once on 1 s of a tone, so the first visitor does
        not wait for it; returns the seconds it took."""
        t0 = time.perf_counter()
        y = (0.3 * np.sin(np.arange(SAMPLE_RATE) / SAMPLE_RATE * 2 * np.pi * 180)).astype(np.float32)
        speech = self.pipeline.prepare_speech(y, SAMPLE_RATE, words=_warmup_words())
        for m in self.pipeline.methods:
            self.pipeline.generate(speech, steps=1, method=m)
        return time.perf_counter() - t0

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
    def _check(self, req: Request, need_file: bool = True) -> None:
        if need_file:
            if not req.audio_path:
                raise ServiceError("Please record or upload speech first (any common audio format).")
            p = Path(req.audio_path)
            if not p.exists():
                raise ServiceError("The uploaded audio file is missing on the server; please upload it again.")
            mb = p.stat().st_size / 2 ** 20
            if mb > self.settings.max_upload_mb:
                raise ServiceError(f"The audio file is {mb:.0f} MB; the limit is {self.settings.max_upload_mb:.0f} MB.")
        methods = list(dict.fromkeys(req.methods or ()))
        if not methods:
            raise ServiceError("Choose at least one method to show.")
        unknown = [m for m in methods if m not in self.methods]
        if unknown:
            raise ServiceError(f"Unknown method {unknown[0]!r}; available: {', '.join(self.methods)}.")
        if not 1 <= int(req.steps) <= self.settings.max_steps:
            raise ServiceError(f"Steps must be from 1 to {self.settings.max_steps} (got {req.steps}).")
        if not 1 <= int(req.ddim_steps) <= 1000:
            raise ServiceError(f"DDIM steps must be from 1 to 1000 (got {req.ddim_steps}).")
        if not (np.isfinite(req.cfg) and 0 <= req.cfg <= 10):
            raise ServiceError(f"CFG scale must be between 0 and 10 (got {req.cfg}).")
        if req.smoothing not in SMOOTHING_WINDOWS:
            raise ServiceError(f"Smoothing must be one of {', '.join(SMOOTHING_WINDOWS)}.")
        if int(req.size) not in VIDEO_SIZES:
            raise ServiceError(f"Video size must be one of {', '.join(map(str, VIDEO_SIZES))}.")

    def _words(self, req: Request):
        if not req.textgrid_path:
            return None
        from .align import TextGridError, read_result

        try:
            return read_result(req.textgrid_path).words
        except TextGridError as exc:
            raise ServiceError(f"The TextGrid could not be read: {exc}") from None

    # ---- one request -----------------------------------------------------------------------------------
    def run(self, req: Request, progress: Progress | None = None, audio: np.ndarray | None = None) -> Outcome:
        """Serve one request (see the module docstring). `audio` (16 kHz) skips reading req.audio_path."""
        from .pipeline import InputError

        t_start = time.perf_counter()
        prog = progress or (lambda f, m: None)
        self.cleanup()
        if audio is None:
            self._check(req)
            try:
                audio = load_audio(req.audio_path)
            except AudioError as exc:
                raise ServiceError(f"The audio could not be read: {exc}") from None
        else:
            self._check(req, need_file=False)
        words = self._words(req)
        out = self.workdir / f"req-{time.strftime('%H%M%S')}-{uuid.uuid4().hex[:8]}"
        out.mkdir(parents=True)
        methods = list(dict.fromkeys(req.methods))
        gen_methods = [m for m in methods if m != "ground_truth"]
        prog(0.02, "reading speech")
        try:
            speech = self.pipeline.prepare_speech(audio, SAMPLE_RATE, words=words, text=req.text or None,
                                                  progress=lambda f, m: prog(0.02 + 0.1 * f, m))
        except InputError as exc:
            raise ServiceError(str(exc)) from None
        T = speech.num_frames
        motions, labels, gen_s, rows, timings = [], [], [], [], {}
        warnings = list(speech.warnings)
        n_gen = max(1, len(gen_methods))
        for i, m in enumerate(gen_methods):
            steps = int(req.ddim_steps if m == "ddim" else req.steps)
            lo, hi = 0.12 + 0.5 * i / n_gen, 0.12 + 0.5 * (i + 1) / n_gen
            try:
                res = self.pipeline.generate(speech, steps=steps, cfg=float(req.cfg), seed=int(req.seed), method=m,
                                             progress=lambda f, msg, lo=lo, hi=hi: prog(lo + (hi - lo) * f, msg))
            except InputError as exc:
                raise ServiceError(str(exc)) from None
            motions.append(res.motion)
            labels.append(f"{METHOD_LABELS.get(m, m)} {steps} steps CFG {req.cfg:g}")
            gen_s.append(res.generation_seconds)
            timings[m] = dict(res.timings)
        gt_name = None
        if "ground_truth" in methods:
            gt_name = find_beat2_take(self.settings.beat2, speech.audio, req.audio_path and Path(req.audio_path).name)
            if gt_name is None:
                warnings.append("Ground truth was asked for, but the speech is not a take of the BEAT2 folder; "
                                "it is left out.")
            else:
                from .data.beat2 import Beat2Dataset

                gt = Beat2Dataset(self.settings.beat2).load(gt_name, with_audio=False, with_text=False).motion
                motions.append(fit_length(gt, T))
                labels.append("Ground truth (BEAT2)")
                gen_s.append(None)
        if not motions:
            raise ServiceError("Nothing to show: choose a generator method.")
        motions = [m.slice(0, T) for m in motions]
        if req.stand_in_place:
            motions = [stand_in_place(m) for m in motions]
        if req.smoothing != "off":
            motions = [smooth(m, req.smoothing) for m in motions]
        motion_s = time.perf_counter() - t_start
        render_args = {"size": int(req.size), "gen_seconds": gen_s, "folder": out}
        video, render_s = None, 0.0
        if req.render:
            video, render_s = self._render(motions, labels, speech.audio, render_args, prog)
        ready = time.perf_counter() - t_start
        shown = gen_methods + (["ground_truth"] if gt_name else [])
        for m in gen_methods:
            t = timings[m]
            t["rendering"] = render_s / len(motions)
            gen = sum(v for k, v in t.items() if k not in ("alignment", "rendering"))
            rows.append([METHOD_LABELS[m], *(round(t.get(k, 0.0), 3) for k in
                                              ("features", "alignment", "sampling", "decoding", "rendering")),
                         round(gen, 3), round(speech.duration / max(gen, 1e-9), 1)])
        if gt_name:
            rows.append(["Ground truth", 0.0, 0.0, 0.0, 0.0, round(render_s / len(motions), 3), 0.0, None])
        rows.append([f"whole request, {speech.duration:.1f} s of speech", None, None, None, None,
                     round(render_s, 3), round(ready, 3), round(speech.duration / max(ready, 1e-9), 2)])
        outcome = Outcome(video, rows, [], None, speech.text_mode, warnings, gt_name, ready, timings,
                          dict(zip(shown, motions)), labels, speech.audio, render_args, motion_s, t_start)
        if req.exports:
            prog(0.93, "exports")
            self.export(outcome)
        prog(1.0, "done")
        return outcome

    def _render(self, motions, labels, audio, args: dict, prog: Progress) -> tuple[Path, float]:
        from .render import RenderError, render_video

        prog(0.62, "rendering video")
        t_r = time.perf_counter()
        video = Path(args["folder"]) / "gestures.mp4"
        try:
            render_video(motions, audio, video, labels=labels, size=(args["size"], args["size"]), body=self.body,
                         gen_seconds=args["gen_seconds"],
                         progress=lambda f, msg: prog(0.62 + 0.3 * f, f"rendering: {msg}"))
        except RenderError as exc:
            raise ServiceError(f"Rendering failed on the server: {exc}") from None
        return video, time.perf_counter() - t_r

    def render(self, outcome: Outcome, progress: Progress | None = None) -> Outcome:
        """Render the video of a request run with `render=False` (the page shows the motions first); fills
        the rendering column of the timing rows and `seconds` (request start to video ready)."""
        if outcome.video is None and outcome.motions:
            motions = list(outcome.motions.values())
            outcome.video, render_s = self._render(motions, outcome.labels, outcome.audio, outcome.render_args,
                                                   progress or (lambda f, m: None))
            for row in outcome.rows[:-1]:
                row[5] = round(render_s / len(motions), 3)
            outcome.seconds = time.perf_counter() - outcome.started
            speech_s = len(outcome.audio) / SAMPLE_RATE if outcome.audio is not None else 0.0
            outcome.rows[-1][5:8] = [round(render_s, 3), round(outcome.seconds, 3),
                                     round(speech_s / max(outcome.seconds, 1e-9), 2)]
        return outcome

    def export(self, outcome: Outcome) -> Outcome:
        """Write the downloads of a finished request (the page shows the video first, then calls this)."""
        motions = outcome.motions
        if motions and not outcome.downloads:
            outcome.downloads, outcome.glb = self._exports(list(motions.values()), list(motions), outcome.video.parent)
        return outcome

    def _exports(self, motions: list[MotionSequence], names: list[str], out: Path) -> tuple[list[Path], Path | None]:
        """npz + BVH per method, GLB + keypoints for the first one (the interactive view shows that GLB)."""
        from .export import export_bvh, export_glb, export_keypoints, export_npz

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


def _warmup_words() -> list:
    from .align import Word

    return [Word("hello", 0.1, 0.5), Word("there", 0.5, 0.9)]


def duration_seconds(path: str | os.PathLike) -> float:
    """Seconds of audio in a file (for limits shown before the work starts)."""
    return len(load_audio(path)) / SAMPLE_RATE


__all__ = ["GestureService", "Outcome", "Request", "ServiceError", "ServiceSettings", "METHOD_LABELS",
           "SMOOTHING_WINDOWS", "TIMING_COLUMNS", "VIDEO_SIZES", "find_beat2_take", "fit_length", "smooth",
           "stand_in_place"]
