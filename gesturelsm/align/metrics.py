"""Word-onset accuracy of an alignment against reference timings (e.g. a forced aligner's TextGrid).

Words are paired by their spoken forms in order (difflib matching), so a transcript tokenised differently
from the reference still pairs the words both have. Errors are absolute onset differences in milliseconds.
"""
from __future__ import annotations

import difflib
from dataclasses import dataclass

import numpy as np

from .normalize import speak
from .words import Word


@dataclass(frozen=True)
class OnsetStats:
    n: int
    mean_ms: float
    median_ms: float
    p90_ms: float
    within_100ms: float  # share of words, 0..1

    def row(self) -> str:
        return f"{self.n} | {self.mean_ms:.0f} | {self.p90_ms:.0f} | {100 * self.within_100ms:.0f} %"


def onset_errors_ms(pred: list[Word], ref: list[Word]) -> np.ndarray:
    """|pred onset - ref onset| in ms for every pair of words matched by spoken form, in order."""
    a = [speak(w.text) for w in pred]
    b = [speak(w.text) for w in ref]
    sm = difflib.SequenceMatcher(a=a, b=b, autojunk=False)
    errs = []
    for block in sm.get_matching_blocks():
        for k in range(block.size):
            errs.append(abs(pred[block.a + k].start - ref[block.b + k].start) * 1000.0)
    return np.array(errs, float)


def onset_stats(errors_ms: np.ndarray) -> OnsetStats:
    e = np.asarray(errors_ms, float)
    if len(e) == 0:
        return OnsetStats(0, float("nan"), float("nan"), float("nan"), 0.0)
    return OnsetStats(len(e), float(e.mean()), float(np.median(e)), float(np.percentile(e, 90)),
                      float(np.mean(e < 100.0)))
