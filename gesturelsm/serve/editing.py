"""An edit of one shown motion for the page, without UI: `GesturePipeline.edit` on the motion a result shows, from
the speech prepared for it and with the settings it was made with (steps, CFG, smoothing, stand in place, grounding
on the service's body), as a new `Result` whose `previous` is the result edited (undo goes back to it, files and
all). The new result has a folder of its own inside the request's (the previous result's files stay as they were);
its video and downloads are made by `GestureService.render` and `.export` as a generated result's are.
"""
from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path
from typing import Sequence

import numpy as np

from ..backends import GROUND_TRUTH, label
from ..constants import Progress
from ..errors import InputError
from ..motion.regions import GENERATED_REGIONS
from ..settings.check import checked_seed
from ..request_files import edit_name
from .request import EditTiming, Result

EDITED = ", edited"          # appended once to an edited motion's label (player and video)


def editable(pipeline, result: Result | None) -> list[str]:
    """The methods of `result`'s motions that can be edited (a loaded method whose sampler holds known latents)."""
    if result is None:
        return []
    return [m for m in result.motions if m != GROUND_TRUTH and m in pipeline.methods and pipeline.spec(m).inpainting]


def root_folder(result: Result) -> Path:
    """The request's own folder (edits are folders inside it)."""
    while result.previous is not None:
        result = result.previous
    return result.job.folder


def _number(value) -> float | None:
    """A finite number from what a page or an API client sent, else None."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if np.isfinite(v) else None


def _checked(pipeline, result: Result | None, method: str, start, end, regions, seed
             ) -> tuple[list[str], float, float, int]:
    if result is None or not result.motions or result.speech is None or result.plan is None:
        raise InputError("Generate first: there is no motion to edit yet.")
    able = editable(pipeline, result)
    if method not in able:
        names = ", ".join(label(m) for m in able) or "none of the shown ones"
        raise InputError(f"Choose a shown motion to edit; the methods that can edit: {names}.")
    a, b = _number(start), _number(end)
    if a is None or b is None:
        raise InputError("Give the time range to regenerate: its start and end in seconds.")
    regions = [regions] if isinstance(regions, str) else list(regions or ())
    chosen = [r for r in GENERATED_REGIONS if r in set(regions)]
    unknown = sorted(set(map(str, regions)) - set(GENERATED_REGIONS))
    if unknown:
        raise InputError(f"Unknown body region {unknown[0]!r}; the regions are {', '.join(GENERATED_REGIONS)}.")
    if not chosen:
        raise InputError("Choose at least one body region to regenerate (upper, hands, lower, face).")
    return chosen, a, b, checked_seed(seed)        # the settings' validator: its bounds and its message


def edit_result(pipeline, result: Result | None, method: str, start, end, regions: Sequence[str], seed,
                progress: Progress | None = None, body=None) -> Result:
    """`result` with `method`'s motion regenerated over [start, end] seconds in `regions` (module docstring)."""
    chosen, start, end, seed = _checked(pipeline, result, method, start, end, regions, seed)
    t0 = time.perf_counter()
    plan = result.plan
    res = pipeline.edit(result.motions[method], result.speech, {r: [(start, end)] for r in chosen},
                        method=method, steps=plan.steps_for(method), cfg=plan.settings.cfg, seed=seed,
                        post=plan.settings.post, body=body, progress=progress)
    folder = root_folder(result) / edit_name(len(result.edits) + 1)
    folder.mkdir(parents=True)
    motions = {**result.motions, method: res.motion}
    i = list(result.motions).index(method)
    labels = list(result.job.labels)
    if i < len(labels) and not labels[i].endswith(EDITED):
        labels[i] += EDITED
    seconds = time.perf_counter() - t0
    job = replace(result.job, folder=folder, motions=tuple(motions.values()), labels=tuple(labels),
                  started=time.perf_counter() - seconds)
    what = (f"{label(method)}: {', '.join(chosen)} {start:.2f}-{end:.2f} s, "
            f"seed {seed} ({seconds:.2f} s)")
    warnings = (*result.warnings, *(w for w in res.warnings if w not in result.warnings))
    own = EditTiming(f"{label(method)}, edit {len(result.edits) + 1}",
                     {k: v for k, v in res.timings.items() if k not in result.speech.timings}, seconds)
    return replace(result, video=None, downloads=(), glb=None, warnings=warnings, seconds=seconds, motions=motions,
                   job=job, previous=result, edits=(*result.edits, what), edit_timings=(*result.edit_timings, own))


def edited_method(result: Result) -> str | None:
    """The method the newest edit changed (None for a generated result)."""
    if result.previous is None:
        return None
    return next((m for m in result.motions if result.motions[m] is not result.previous.motions.get(m)), None)


__all__ = ["EDITED", "edit_result", "editable", "edited_method", "root_folder"]
