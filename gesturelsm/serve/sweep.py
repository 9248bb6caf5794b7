"""A sweep (methods x steps x CFG x seeds on one upload, `gesturelsm.evaluation.sweep`) as one web request: the
page's Sweep tab and its API call `GestureService.sweep`, which takes the path of a request (`run_sweep_request` with
the server's `Workshop`): the upload's checks,
the settings' validator with the server's limits (its step caps included), the speech read and prepared once with
the transcript the request asks for (typed, recognised automatically or none), and a request folder that is
deleted like the others; then the sweep, its files and the speech for the player.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import soundfile as sf

from ..constants import SAMPLE_RATE, Progress
from ..errors import InputError
from ..evaluation.sweep import DEFAULT_CFGS, DEFAULT_STEPS, SweepLimits, SweepResult, check_grid, run_sweep, sweep_grid
from ..evaluation.sweep_report import PLOT_METRICS, write_sweep
from ..settings import DEFAULTS, PAGE
from ..settings.values import one_of
from .names import SPEECH, SWEEP
from .request import Request
from .workshop import Workshop


@dataclass
class SweepRequest:
    """A sweep as sent: lists as text ("1 2 4 8") or lists, numbers as sent."""
    audio_path: Any
    methods: Any
    steps: Any = DEFAULT_STEPS
    cfgs: Any = DEFAULT_CFGS
    seeds: Any = 1
    metric: Any = "wrist_speed"              # the statistic plotted (evaluation.sweep_report.PLOT_METRICS)
    text: Any = ""
    transcribe: Any = DEFAULTS.transcribe    # automatic transcript when no text is typed (as Generate)
    language: Any = DEFAULTS.language        # the speech's language (auto: English, else the one identified)


@dataclass(frozen=True)
class SweepOutcome:
    result: SweepResult
    folder: Path                             # the request's folder
    files: dict[str, Path]                   # sweep.csv, .md, .json, .png
    wav: Path                                # the speech, for the player
    notes: tuple[str, ...]                   # what the visitor should know (transcript warnings)


def run_sweep_request(shop: Workshop, req: SweepRequest, limits: SweepLimits, progress: Progress | None,
                      cancelled: Callable[[], bool] | None) -> SweepOutcome:
    """See the module docstring. Every problem of the request at once (InputError), before any work."""
    prog = progress or (lambda f, m: None)
    pipeline, intake = shop.pipeline, shop.intake
    shop.folders.cleanup()
    problems: list[str] = []
    grid = None
    try:
        grid = sweep_grid(req.methods, req.steps, req.cfgs, req.seeds, pipeline.methods, limits, intake.limits, PAGE)
    except InputError as exc:
        problems += str(exc).splitlines()
    metric = one_of(req.metric, "Statistic", PLOT_METRICS, problems)
    methods = grid.methods if grid else pipeline.methods[:1]
    base = Request(req.audio_path, text=req.text, methods=methods, transcribe=req.transcribe, language=req.language,
                   render=False, exports=False)
    base, _, audio = intake.load(base, extra=problems)
    check_grid(pipeline, grid, len(audio) / SAMPLE_RATE, limits)
    plan, speech, notes = intake.speech(base, audio, lambda f, m: prog(0.1 * f, m))
    result = run_sweep(pipeline, speech, grid, progress=lambda f, m: prog(0.1 + 0.85 * f, m),
                       cancelled=cancelled)
    folder = shop.folders.new()
    files = write_sweep(result, folder / SWEEP, metric)
    wav = folder / SPEECH
    sf.write(wav, speech.audio, SAMPLE_RATE, subtype="PCM_16")
    return SweepOutcome(result, folder, files, wav, (*speech.warnings, *notes))


__all__ = ["SweepOutcome", "SweepRequest", "run_sweep_request"]
