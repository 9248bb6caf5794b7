"""Where speech is cut into recognition windows, so that its words can be recognised and timed window by window while
the motion of the first windows is already being generated.

Whisper reads 30 s at a time and pads shorter audio to 30 s, so every window costs one encoder pass whatever its
length: the first window is short (FIRST_WINDOW_S, so the words the first generation window needs, up to ~8 s with
the text features' look-ahead, come early) and the later ones long (WINDOW_S, few encoder passes). Each cut is placed
at the quietest 0.1 s within SEARCH_S before its target time, a pause where there is one, so that no word straddles a
cut and no overlap is needed (each window is recognised and aligned on its own); the rest of the speech is left whole
when it is at most SLACK_S longer than a window. The cuts depend only on the samples: the one-shot and the pipelined
path cut the same speech the same way.
"""
from __future__ import annotations

import numpy as np

from ..constants import SAMPLE_RATE

FIRST_WINDOW_S = 10.0   # the first window ends 8-10 s in (the first generation window needs the words up to 8 s)
WINDOW_S = 24.0         # later windows: 21-24 s (one Whisper encoder pass each)
SEARCH_S = 2.0          # a cut goes to the quietest 0.1 s of the SEARCH_S before the target
SLACK_S = 4.0           # a rest at most this much longer than a window is not cut (no window shorter than ~4 s)
HOP = SAMPLE_RATE // 100  # 10 ms energy frames
SMOOTH = 10               # frames averaged: 0.1 s


def recognition_cuts(y: np.ndarray, first_s: float = FIRST_WINDOW_S, window_s: float = WINDOW_S,
                     search_s: float = SEARCH_S, slack_s: float = SLACK_S) -> list[int]:
    """Sample indices [0, c1, ..., len(y)]: window j is y[cuts[j]:cuts[j + 1]]."""
    n = len(y)
    frames = n // HOP
    energy = np.square(np.asarray(y[: frames * HOP], np.float64)).reshape(frames, HOP).mean(1) if frames else \
        np.zeros(0)
    smooth = np.convolve(energy, np.ones(SMOOTH) / SMOOTH, mode="same") if frames else energy
    cuts, start, length = [0], 0, first_s
    while (n - start) / SAMPLE_RATE > length + slack_s:
        hi = min(frames - 1, int(round((start / SAMPLE_RATE + length) * 100)))
        lo = max(start // HOP + 1, int(round((start / SAMPLE_RATE + length - search_s) * 100)))
        k = lo + int(np.argmin(smooth[lo:hi + 1])) if hi >= lo else hi
        start = k * HOP
        cuts.append(start)
        length = window_s
    cuts.append(n)
    return cuts
