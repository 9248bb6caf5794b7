"""A sweep (methods x steps x CFG x seeds on one upload, `gesturelsm.evaluation.sweep`) as one web request: the
page's Sweep tab and its API call `GestureService.sweep`, which takes the path of a request (`run_sweep_request` with
the server's `Workshop`): the upload's checks,
the settings' validator with the server's limits (its step caps included), the speech read and prepared once with
the transcript the request asks for (typed, recognised automatically or none), and a request folder that is
deleted like the others; then the sweep, its files and the speech for the player.
"""
from __future__ import annotations

from dataclasses import dataclass, field, make_dataclass
from pathlib import Path
from typing import Any, Callable

import soundfile as sf

from ..constants import SAMPLE_RATE, Progress
from ..evaluation.sweep import (DEFAULT_CFGS, DEFAULT_STEPS, SweepGrid, SweepLimits, SweepResult, check_grid, run_sweep,
                                sweep_problems)
from ..evaluation.sweep_limits import sweep_settings
from ..evaluation.sweep_report import PLOT_METRICS, write_sweep
from ..progress import SWEEP_REQUEST
from ..settings import PAGE, Limits
from ..settings.check import asked_of
from ..settings.values import one_of
from ..request_files import SPEECH, SWEEP
from .request import Request
from .workshop import Workshop

SWEEP_DOC = """A sweep as sent: the speech, the methods, the grid's lists as text ("1 2 4 8") or lists, the seed count,
the plotted statistic and the transcript, then every setting a sweep takes one value of by its name
(`evaluation.sweep_limits.sweep_settings`: feet on the ground, transcription, language, any setting added), with its
default; each checked by the settings' validator, as for Generate."""


def sweep_request_class(cls: type | None = None) -> type:
    """The sweep request's dataclass: its own fields, then one per setting of `sweep_settings(cls)` (the methods are
    its second field, sent always)."""
    own = [("audio_path", Any), ("methods", Any), ("steps", Any, field(default=DEFAULT_STEPS)),
           ("cfgs", Any, field(default=DEFAULT_CFGS)), ("seeds", Any, field(default=1)),
           ("metric", Any, field(default="wrist_speed")),       # the statistic plotted (sweep_report.PLOT_METRICS)
           ("text", Any, field(default=""))]
    settings = [(s.name, Any, field(default=s.default)) for s in sweep_settings(cls) if s.name != "methods"]
    made = make_dataclass("SweepRequest", [*own, *settings], namespace={"__doc__": SWEEP_DOC})
    made.__module__ = __name__
    return made


SweepRequest = sweep_request_class()


def checked_sweep(req: Any, available: list[str], limits: SweepLimits, settings_limits: Limits,
                  problems: list[str]) -> tuple[dict[str, Any], SweepGrid | None, str | None]:
    """(the settings part by name, checked, for the sweep's request; the grid; the statistic), every problem added to
    `problems` (one line each): the settings part by the settings' validator with Generate's words and the grid's
    lists (`evaluation.sweep.sweep_problems`). A settings part with a problem is left to its defaults (its problems
    are said once)."""
    values = {s.name: getattr(req, s.name) for s in sweep_settings()}
    settings, grid = sweep_problems(values, req.steps, req.cfgs, req.seeds, available, limits, settings_limits, PAGE,
                                    problems)
    metric = one_of(req.metric, "Statistic", PLOT_METRICS, problems)
    part = {} if settings is None else {s.name: getattr(asked_of(settings), s.name) for s in sweep_settings()}
    return part, grid, metric


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
    part, grid, metric = checked_sweep(req, list(pipeline.methods), limits, intake.limits, problems)
    base = Request(req.audio_path, text=req.text, **{"methods": pipeline.methods[:1], **part},
                   render=False, exports=False)
    base, _, audio = intake.load(base, extra=problems)
    check_grid(pipeline, grid, len(audio) / SAMPLE_RATE, limits)
    plan, speech, notes = intake.speech(base, audio, SWEEP_REQUEST.span(prog, "speech"))
    result = run_sweep(pipeline, speech, grid, progress=SWEEP_REQUEST.span(prog, "sweep"),
                       cancelled=cancelled, grounding=plan.settings.post.grounding)
    folder = shop.folders.new()
    files = write_sweep(result, folder / SWEEP, metric)
    wav = folder / SPEECH
    sf.write(wav, speech.audio, SAMPLE_RATE, subtype="PCM_16")
    return SweepOutcome(result, folder, files, wav, (*speech.warnings, *notes))


__all__ = ["SweepOutcome", "SweepRequest", "checked_sweep", "run_sweep_request", "sweep_request_class"]
