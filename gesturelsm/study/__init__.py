"""User studies: blinded videos of every speech x method with a key kept apart (`gesturelsm batch`), a web study
of pairwise preferences or 1-5 ratings with attention checks (`gesturelsm study serve`), responses in a
database, and results with statistics (`gesturelsm study results`).

    from gesturelsm.settings import Settings
    from gesturelsm.study import make_study
    make_study(pipeline, "speech/", "study/", Settings(methods=("gesturelsm", "ddim")), raters=10)

The rendering side (batch) is imported on first use, so the server and the analysis start without torch.
"""
from __future__ import annotations

from .design import SCALES, Design

_BATCH = ("AUDIO_EXTENSIONS", "StudyPlan", "make_study", "plan_study")


def __getattr__(name: str):
    if name in _BATCH:
        from . import batch

        return getattr(batch, name)
    raise AttributeError(name)


__all__ = ["AUDIO_EXTENSIONS", "SCALES", "Design", "StudyPlan", "make_study", "plan_study"]
