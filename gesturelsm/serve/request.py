"""The values one web request passes through, each typed and never edited in place:

- `ServiceSettings`: the server's limits and folders (the `python -m app` / `gesturelsm serve` flags).
- `Request`: what a visitor or API client asks for, as sent (`serve/checks.py` checks and normalises it).
- `RenderJob`: everything the side-by-side video of a request needs, fixed once the motions exist (motions,
  labels, the speech, size, folder, the request's start time), so the video can be rendered later.
- `Result`: what the visitor sees (video, timing rows, downloads, summary) plus the job that renders its video;
  `GestureService.render` and `.export` return a new `Result` with the video or the downloads filled in, and
  `GestureService.edit` one with a motion edited (the result before it is its `previous`: undo).
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from ..flows import DEFAULT_STEPS
from ..motion.postprocess import DEFAULT_SMOOTHING
from ..motion.sequence import MotionSequence
from ..pipeline import FACTS, GROUND_TRUTH, Plan, SpeechInput, generation_seconds
from ..presentation import LABELS

METHOD_LABELS = dict(LABELS)                            # every method, then ground truth: the page's order
VIDEO_SIZES = (256, 384, 512, 640)
STAGES = ("features", "alignment", "transcription", "sampling", "decoding", "rendering")      # seconds each


@dataclass(frozen=True)
class TimingRow:
    """One row of the page's timing table: a method, the ground truth or the whole request (`method` is the label
    shown); seconds per stage, the generation time and the real-time factor (speech seconds per generation second).
    None: a cell left empty."""
    method: str
    features: float | None
    alignment: float | None
    transcription: float | None
    sampling: float | None
    decoding: float | None
    rendering: float | None
    generation: float | None
    real_time_factor: float | None = field(metadata={"column": "real-time factor"})

    def cells(self) -> list:
        """The row as the table shows it, in TIMING_COLUMNS order."""
        return [getattr(self, f.name) for f in fields(self)]


TIMING_COLUMNS = [f.metadata.get("column", f.name) for f in fields(TimingRow)]


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
    grounding: bool = True                   # feet on the ground (gesturelsm.grounding)

    def plan(self, beat2: str | None = None) -> Plan:
        steps = self.steps if isinstance(self.steps, Mapping) else {k: int(self.steps) for k in FACTS}
        return Plan(list(dict.fromkeys(self.methods or ())), dict(steps), float(self.cfg), int(self.seed),
                    bool(self.stand_in_place), str(self.smoothing), beat2,
                    Path(self.audio_path).name if self.audio_path else None, bool(self.grounding))


@dataclass(frozen=True, eq=False)
class RenderJob:
    """The side-by-side video of one request: what `render/background.py` draws, and where."""
    folder: Path                                       # the request's own folder (128 random bits in its name)
    motions: tuple[MotionSequence, ...] = field(repr=False)   # shown, post-processed, in page order
    labels: tuple[str, ...]                            # one per motion, as drawn in the video
    gen_seconds: tuple[float | None, ...]              # generation time per motion (None: ground truth)
    audio: np.ndarray = field(repr=False)              # the speech, 16 kHz mono
    speech_seconds: float                              # the speech's length (motion frames / 30)
    size: int                                          # pixels per body, square
    started: float                                     # time.perf_counter() at the request's start
    grounding: bool = True                             # feet on the ground: a character's too, on its own legs


@dataclass(frozen=True, eq=False)
class Result:
    """What one request shows the visitor; `video` is None until rendered, `downloads` empty until exported."""
    video: Path | None
    rows: tuple[TimingRow, ...]              # per method, then the ground truth (if shown), then the whole request
    downloads: tuple[Path, ...]
    glb: Path | None
    text_mode: str
    warnings: tuple[str, ...]
    ground_truth: str | None                 # the BEAT2 take recognised, if any
    seconds: float                           # request start to video ready (to motions ready before the video)
    motion_seconds: float                    # request start to motions ready
    timings: Mapping[str, Mapping[str, float]]              # per generator and stage, seconds
    motions: Mapping[str, MotionSequence] = field(repr=False)   # shown, post-processed, by method
    transcript: str | None                   # the automatic transcript used (shown in the transcript box)
    job: RenderJob = field(repr=False)
    speech: SpeechInput | None = field(default=None, repr=False)   # prepared once: edits reuse it
    plan: Plan | None = None                 # the settings the motions were made with (edits use them too)
    previous: "Result | None" = field(default=None, repr=False)    # the result before an edit (undo goes back to it)
    edits: tuple[str, ...] = ()              # the edits made since Generate, oldest first, as the summary says them

    @property
    def table(self) -> list[list]:
        """The timing rows as the page's table (and the API) shows them: one list of TIMING_COLUMNS cells each."""
        return [r.cells() for r in self.rows]

    @property
    def summary(self) -> str:
        lines = [f"**Transcript:** {self.text_mode}", f"**Motion ready in {self.motion_seconds:.1f} s.** " +
                 (f"**Video ready in {self.seconds:.1f} s.**" if self.video else "Rendering the video (mp4)...")]
        if self.ground_truth:
            lines.append(f"**Ground truth:** BEAT2 take `{self.ground_truth}`")
        lines += [f"**Edited:** {e}" for e in self.edits]
        lines += [f"Note: {w}" for w in self.warnings]
        return "\n\n".join(lines)


def timing_rows(timings: Mapping[str, Mapping[str, float]], ground_truth: bool, duration: float, render_s: float,
                ready: float) -> tuple[tuple[TimingRow, ...], dict[str, dict[str, float]]]:
    """(A row per generator, the ground truth's, then the whole request's; each generator's timings with its share
    of the rendering, which is split evenly over the shown motions)."""
    n = len(timings) + int(ground_truth)
    rows, shared = [], {}
    for m, t in timings.items():
        shared[m] = {**t, "rendering": render_s / n}
        g = generation_seconds(t)
        rows.append(TimingRow(METHOD_LABELS[m], *(round(shared[m].get(k, 0.0), 3) for k in STAGES), round(g, 3),
                              round(duration / max(g, 1e-9), 1)))
    if ground_truth:
        rows.append(TimingRow("Ground truth", 0.0, 0.0, 0.0, 0.0, 0.0, round(render_s / n, 3), 0.0, None))
    rows.append(TimingRow(f"whole request, {duration:.1f} s of speech", None, None, None, None, None,
                          round(render_s, 3), round(ready, 3), round(duration / max(ready, 1e-9), 2)))
    return tuple(rows), shared
