"""The values one web request passes through, each typed and never edited in place:

- `ServiceSettings` (`config.py`): the server's limits and folders (the `python -m app` / `gesturelsm serve` flags).
- `Request`: what a visitor or API client asks for, as sent (`serve/checks.py` checks it with the settings'
  validator, `gesturelsm.settings`, and makes its `Plan`).
- `RenderJob`: everything the side-by-side video of a request needs, fixed once the motions exist (motions,
  labels, the speech, size, folder, the request's start time), so the video can be rendered later.
- `Result`: what the visitor sees (video, timing rows, downloads, summary) plus the job that renders its video;
  `GestureService.render` and `.export` return a new `Result` with the video or the downloads filled in, and
  `GestureService.edit` one with a motion edited (the result before it is its `previous`: undo).
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ..backends import GROUND_TRUTH_LABEL, label
from ..motion.sequence import MotionSequence
from ..pipeline import Plan, SpeechInput, generation_seconds
from ..settings import DEFAULTS, MISSING

VIDEO_SIZES = (256, 384, 512, 640)
DEFAULT_SIZE = 384                                       # pixels per body in the page's video
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


@dataclass
class Request:
    """One request as sent; the settings fields take whatever arrived (`Asked`), MISSING: the default."""
    audio_path: str | None
    text: str = ""
    textgrid_path: str | None = None
    methods: Sequence[str] = DEFAULTS.methods
    steps: Mapping[str, Any] | Any = MISSING  # {method: steps}, or one value (for "Steps" methods when ddim_steps
    ddim_steps: Any = MISSING                 # is given too); MISSING: each method's own default
    cfg: float = DEFAULTS.cfg
    seed: int = DEFAULTS.seed
    stand_in_place: bool = DEFAULTS.post.stand_in_place
    smoothing: str = DEFAULTS.post.smoothing
    size: int = DEFAULT_SIZE
    exports: bool = True
    transcribe: bool = DEFAULTS.transcribe   # automatic transcript when neither text nor TextGrid is given
    render: bool = True                      # False: motions only (the page's player); GestureService.render later
    grounding: bool = DEFAULTS.post.grounding   # feet on the ground (gesturelsm.grounding)
    language: str = DEFAULTS.language        # the speech's language (auto: English, else the one identified)


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
    pending: tuple[str, ...] = ()            # methods still being made (a result that grows: serve/progressive.py)
    failed: Mapping[str, str] = field(default_factory=dict)       # method -> why it has no motion
    slots: tuple[tuple[str, str], ...] = ()  # (method, label) of every method shown, made or not, in page order

    @property
    def table(self) -> list[list]:
        """The timing rows as the page's table (and the API) shows them: one list of TIMING_COLUMNS cells each."""
        return [r.cells() for r in self.rows]

    @property
    def summary(self) -> str:
        if self.pending:
            made = ", ".join(label(m) for m in self.motions) or "nothing yet"
            ready = (f"**Ready after {self.motion_seconds:.1f} s:** {made}. **Generating:** "
                     f"{', '.join(label(m) for m in self.pending)}...")
        else:
            ready = f"**Motion ready in {self.motion_seconds:.1f} s.** " + (
                f"**Video ready in {self.seconds:.1f} s.**" if self.video else "Rendering the video (mp4)...")
        lines = [f"**Transcript:** {self.text_mode}", ready]
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
        rows.append(TimingRow(label(m), *(round(shared[m].get(k, 0.0), 3) for k in STAGES), round(g, 3),
                              round(duration / max(g, 1e-9), 1)))
    if ground_truth:
        rows.append(TimingRow(GROUND_TRUTH_LABEL, 0.0, 0.0, 0.0, 0.0, 0.0, round(render_s / n, 3), 0.0, None))
    rows.append(TimingRow(f"whole request, {duration:.1f} s of speech", None, None, None, None, None,
                          round(render_s, 3), round(ready, 3), round(duration / max(ready, 1e-9), 2)))
    return tuple(rows), shared
