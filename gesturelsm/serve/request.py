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

from dataclasses import dataclass, field, fields, make_dataclass, replace
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ..backends import GROUND_TRUTH_LABEL, label
from ..motion.sequence import MotionSequence
from ..pipeline import Plan, SpeechInput, generation_seconds
from ..pipelined import HIDDEN
from ..settings import settings_of

VIDEO_SIZES = (256, 384, 512, 640)
DEFAULT_SIZE = 384                                       # pixels per body in the page's video
STAGES = ("features", "alignment", "transcription", "sampling", "decoding", "rendering")      # seconds each


def _column(name: str, unit: str):
    """A field of `TimingRow` whose heading says its unit once, so its cells are bare numbers: "sampling (s)"."""
    return field(metadata={"column": f"{name} ({unit})"})


@dataclass(frozen=True)
class TimingRow:
    """One row of the page's timing table: a method, the ground truth or the whole request (`method` is the label
    shown); seconds per stage, the generation time and the real-time factor (speech seconds per generation second).
    Each column's heading says its unit once ("sampling (s)", "real-time factor (×)"); the cells are plain numbers.
    None: a cell left empty."""
    method: str
    features: float | None = _column("features", "s")
    alignment: float | None = _column("alignment", "s")
    transcription: float | None = _column("transcription", "s")
    sampling: float | None = _column("sampling", "s")
    decoding: float | None = _column("decoding", "s")
    rendering: float | None = _column("rendering", "s")
    generation: float | None = _column("generation", "s")
    real_time_factor: float | None = _column("real-time factor", "×")

    def cells(self) -> list:
        """The row as the table shows it, in TIMING_COLUMNS order."""
        return [getattr(self, f.name) for f in fields(self)]


TIMING_COLUMNS = [f.metadata.get("column", f.name) for f in fields(TimingRow)]


REQUEST_DOC = """One request as sent: the speech, its transcript or TextGrid, every setting of the settings object
by its name (`gesturelsm.settings.fields`: whatever arrived, checked into `Asked` by name; a setting's own default,
or MISSING, when not sent), the video size, and whether to export and render (False: motions only, for the page's
player; `GestureService.render` later). `steps`: {method: steps}, or one value (for "Steps" methods when
`ddim_steps` is given too); MISSING: each method's own default."""


def request_class(cls: type | None = None) -> type:
    """The request's dataclass, one field per setting of the settings object `cls` (default: the shipped one)."""
    own_first = [("audio_path", "str | None"), ("text", str, field(default="")),
                 ("textgrid_path", "str | None", field(default=None))]
    settings = [(s.name, Any, field(default=s.default)) for s in settings_of(cls)]
    own_last = [("size", int, field(default=DEFAULT_SIZE)), ("exports", bool, field(default=True)),
                ("render", bool, field(default=True))]
    made = make_dataclass("Request", [*own_first, *settings, *own_last], namespace={"__doc__": REQUEST_DOC})
    made.__module__ = __name__
    return made


Request = request_class()


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


@dataclass(frozen=True)
class EditTiming:
    """One edit's own timings, shown beside the generation's: its row's label, seconds per stage (sampling,
    decoding, ...), its wall time, and its video's render time once rendered."""
    label: str
    stages: Mapping[str, float]
    seconds: float
    rendering: float | None = None


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
    seconds: float                           # request start (the click) to video ready (to motions ready before it)
    motion_seconds: float                    # the click to the generation's motions ready (an edit keeps it)
    timings: Mapping[str, Mapping[str, float]]              # per generator and stage, seconds (rendering: none)
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
    made_ahead: tuple[str, ...] = ()         # methods whose motion was made before the click (serve/ahead.py)
    ahead_seconds: float | None = None       # wall time the motion made before the click took (None: none was)
    speech_ahead: bool = False               # the speech was prepared at the upload, before the click
    render_seconds: float | None = None      # the generation's video's own render time (None: not rendered)
    edit_timings: tuple[EditTiming, ...] = ()   # each edit's own timings, oldest first
    previews: Mapping[str, MotionSequence] = field(default_factory=dict, repr=False)  # raw first windows of a
    # method still being made, by method (serve/preview.py; a result that grows, for the page's player)

    @property
    def table(self) -> list[list]:
        """The timing rows as the page's table (and the API) shows them: one list of TIMING_COLUMNS cells each."""
        return [r.cells() for r in self.rows]

    @property
    def summary(self) -> str:
        return self.summary_with(None)

    def summary_with(self, video_status: str | None) -> str:
        """The summary, with `video_status` (where the video is: its place in the queue, frame k/n and the time
        left) in place of "Rendering the video (mp4)..." while it is not ready."""
        rendering = "(mp4)..." if not video_status else f"(mp4): {video_status.removeprefix('rendering: ')}"
        if self.pending:
            made = ", ".join(label(m) for m in self.motions)
            ready = (f"**Ready {seconds_text(self.motion_seconds)} after the click:** {made}. " if made else "") + \
                f"**Generating:** {', '.join(label(m) for m in self.pending)}..."
        else:
            ready = motion_ready(self)
            if self.edit_timings:
                e = self.edit_timings[-1]
                ready += f" **Edit made in {seconds_text(e.seconds)}.** " + (
                    f"**Its video ready in {seconds_text(self.seconds)}.**" if self.video
                    else f"Rendering the edit's video {rendering}")
            else:
                ready += " " + (f"**Video ready in {seconds_text(self.seconds)}.**" if self.video
                                else f"Rendering the video {rendering}")
        lines = [f"**Transcript:** {self.text_mode}", ready]
        if self.ground_truth:
            lines.append(f"**Ground truth:** BEAT2 take `{self.ground_truth}`")
        lines += [f"**Edited:** {e}" for e in self.edits]
        lines += [f"Note: {w}" for w in self.warnings]
        return "\n\n".join(lines)


def seconds_text(s: float | None) -> str:
    """Seconds as the summary says them: one decimal, and never "0.0 s" for work that took time."""
    if s is None:
        return "-"
    return "under 0.1 s" if s < 0.05 else f"{s:.1f} s"


def motion_ready(result: "Result") -> str:
    """The summary's line on the generation's motion: after the click, and what was made before it."""
    if result.made_ahead:
        ahead = (f" (made ahead: {seconds_text(result.ahead_seconds)} of generation before the click)"
                 if result.ahead_seconds is not None else " (made ahead, before the click)")
        return f"**Motion ready {seconds_text(result.motion_seconds)} after the click**{ahead}."
    return f"**Motion ready in {seconds_text(result.motion_seconds)}.**"


AHEAD = " (made ahead)"                      # appended to the label of a row whose work was done before the click


def _shared(timings: Mapping[str, Mapping[str, float]], stage: str) -> float | None:
    """A stage of the speech's, done once for every method (features, alignment, transcription)."""
    values = [t[stage] for t in timings.values() if stage in t]
    return max(values) if values else None


HIDDEN_ROW = "of the transcription, hidden under generation"


def timing_rows(timings: Mapping[str, Mapping[str, float]], ground_truth: bool, duration: float,
                render_s: float | None, made_ahead: Sequence[str] = (), speech_ahead: bool = False,
                edits: Sequence[EditTiming] = (), words_ahead: bool = False) -> tuple[TimingRow, ...]:
    """The timing table: a row per generator (its own stages and generation time, "(made ahead)" when it was made
    before the click), the ground truth's, one per edit (its own stages and video), then the whole request's.

    Every figure is the time the work took where it was spent: the speech's stages (features, alignment,
    transcription) are done once for all methods and shown in each row as they took, also when they were done at the
    upload or its words recognised before the click (the whole request's row says which); the video is one render of
    all the methods side by side, so its time is the whole request's (an edit's video is the edit's row's), never
    split over the methods. The whole request's
    generation is the work of all its methods (the speech's features once, each method's sampling and decoding), so
    it is never below one method's. Where the words were recognised while the first method was generated (pipelined
    speech), a row before the whole request's says how much of the transcription ran hidden under that generation."""
    rows = []
    gens = {}
    for m, t in timings.items():
        g = generation_seconds(t)
        gens[m] = g
        rows.append(TimingRow(label(m) + (AHEAD if m in made_ahead else ""),
                              *(_cell(t.get(k, 0.0)) for k in STAGES[:-1]), None, round(g, 3),
                              round(duration / max(g, 1e-9), 1)))
    if ground_truth:
        rows.append(TimingRow(GROUND_TRUTH_LABEL, None, None, None, None, None, None, None, None))
    for e in edits:
        g = generation_seconds(e.stages)
        rows.append(TimingRow(e.label, *(_cell(e.stages.get(k)) for k in STAGES[:-1]),
                              _cell(e.rendering), round(g, 3), None))
    hidden = _shared(timings, HIDDEN)
    if hidden:
        rows.append(TimingRow(HIDDEN_ROW, None, None, round(hidden, 3), None, None, None, None, None))
    features = _shared(timings, "features") or 0.0
    whole = features + sum(g - timings[m].get("features", 0.0) for m, g in gens.items())
    where = ", speech prepared at the upload" if speech_ahead else ", words recognised earlier" if words_ahead \
        else ""
    where += ", motion made ahead" if made_ahead else ""
    rows.append(TimingRow(f"whole request, {duration:.1f} s of speech{where}",
                          _cell(_shared(timings, "features")), _cell(_shared(timings, "alignment")),
                          _cell(_shared(timings, "transcription")),
                          _cell(sum(t.get("sampling", 0.0) for t in timings.values()) if timings else None),
                          _cell(sum(t.get("decoding", 0.0) for t in timings.values()) if timings else None),
                          _cell(render_s), round(whole, 3) if gens else None,
                          round(duration / max(whole, 1e-9), 2) if gens else None))
    return tuple(rows)


def _cell(v: float | None) -> float | None:
    return None if v is None else round(float(v), 3)


def with_render_time(result: Result, render_s: float, ready: float) -> Result:
    """`result` (its video just made) with the video's own render time in its rows (the edit's row for an edited
    result) and `seconds` (request or edit start to video ready)."""
    if result.edit_timings:
        edits = (*result.edit_timings[:-1], replace(result.edit_timings[-1], rendering=render_s))
        result = replace(result, edit_timings=edits)
    else:
        result = replace(result, render_seconds=render_s)
    return replace(result, rows=result_rows(result), seconds=ready)


def result_rows(result: Result):
    """The timing table of `result` (`request.timing_rows`) from what it holds."""
    return timing_rows(result.timings, result.ground_truth is not None, result.job.speech_seconds,
                       result.render_seconds, result.made_ahead, result.speech_ahead, result.edit_timings,
                       words_ahead=not result.speech_ahead and result.speech is not None
                       and "transcription" in result.speech.earlier)
