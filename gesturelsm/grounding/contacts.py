"""Foot contacts from height and speed, with hysteresis: a foot lands when it has been low and slow for a few
frames, and lifts when it has been high or fast for a few frames; between the two thresholds it keeps its state,
so a foot hovering at one threshold does not flicker.

- `ContactDetector`: the causal state machine, one frame at a time (live mode); its state lags the foot by
  `frames_on` / `frames_off` frames.
- `detect_contacts`: the same machine over a whole take at once (vectorised, equal to running the detector), then,
  knowing the future, each contact is moved back to when its foot really landed (first low and slow) and lifted
  (last low and slow before it rose), gaps shorter than `min_gap` are closed and contacts shorter than
  `min_contact` dropped.

Heights are the foot's lowest point above the supporting floor (m), speeds its horizontal speed (m/s), per frame and
foot: (T, F) arrays.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ContactParams:
    height_on: float = 0.03         # m: lands below this ...
    speed_on: float = 0.35          # m/s: ... and slower than this
    height_off: float = 0.06        # m: lifts above this ...
    speed_off: float = 0.7          # m/s: ... or faster than this
    frames_on: int = 3              # consecutive frames a condition must hold
    frames_off: int = 3
    min_gap: int = 4                # offline: shorter lifts are closed (frames)
    min_contact: int = 6            # offline: shorter contacts are dropped (frames)


class ContactDetector:
    """The causal contact state of F feet, one frame at a time."""

    def __init__(self, feet: int = 2, params: ContactParams = ContactParams()):
        self.params = params
        self.state = np.zeros(feet, bool)
        self._on = np.zeros(feet, int)         # consecutive frames low and slow
        self._off = np.zeros(feet, int)        # consecutive frames high or fast

    def step(self, height: np.ndarray, speed: np.ndarray) -> np.ndarray:
        """(F,) heights and speeds of this frame -> (F,) contact states after it."""
        p = self.params
        h, v = np.asarray(height, np.float64), np.asarray(speed, np.float64)
        on = (h < p.height_on) & (v < p.speed_on)
        off = (h > p.height_off) | (v > p.speed_off) | ~np.isfinite(h) | ~np.isfinite(v)
        self._on = np.where(on, self._on + 1, 0)
        self._off = np.where(off, self._off + 1, 0)
        self.state = np.where(self._on >= p.frames_on, True, np.where(self._off >= p.frames_off, False, self.state))
        return self.state.copy()


def _held(cond: np.ndarray, n: int) -> np.ndarray:
    """(T, F): cond has held for the last n frames (this one included)."""
    c = np.cumsum(np.vstack([np.zeros((1, cond.shape[1]), int), cond.astype(int)]), axis=0)
    out = np.zeros(cond.shape, bool)
    out[n - 1:] = (c[n:] - c[:-n]) == n
    return out


def causal_contacts(height: np.ndarray, speed: np.ndarray, params: ContactParams = ContactParams()) -> np.ndarray:
    """(T, F) what `ContactDetector` reports frame by frame, computed for all frames at once."""
    p = params
    h, v = np.asarray(height, np.float64), np.asarray(speed, np.float64)
    on = _held((h < p.height_on) & (v < p.speed_on), max(1, p.frames_on))
    off = _held((h > p.height_off) | (v > p.speed_off) | ~np.isfinite(h) | ~np.isfinite(v), max(1, p.frames_off))
    event = np.where(on, 1, np.where(off, -1, 0))                       # (T, F)
    T = len(event)
    idx = np.where(event != 0, np.arange(T)[:, None], -1)
    last = np.maximum.accumulate(idx, axis=0)                           # the latest event so far
    got = np.take_along_axis(event, np.maximum(last, 0), axis=0)
    return (last >= 0) & (got == 1)


def segments(mask: np.ndarray) -> list[tuple[int, int]]:
    """[(start, stop)] of the True runs of a (T,) mask, stop exclusive."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    d = np.flatnonzero(np.diff(m.astype(int)))
    return list(zip(d[::2].tolist(), d[1::2].tolist()))


def detect_contacts(height: np.ndarray, speed: np.ndarray, params: ContactParams = ContactParams()) -> np.ndarray:
    """(T, F) contacts of a whole take (see the module docstring)."""
    p = params
    state = causal_contacts(height, speed, p)
    T, F = state.shape
    low = (np.asarray(height, np.float64) < p.height_on) & (np.asarray(speed, np.float64) < p.speed_on)
    out = np.zeros_like(state)
    for f in range(F):
        runs = []
        for a, b in segments(state[:, f]):
            a = max(0, a - (p.frames_on - 1))                           # it landed when it first got low and slow
            if b < T:                                                   # ... and lifted after it last was
                b = a + 1 + int(np.flatnonzero(low[a:b, f])[-1]) if low[a:b, f].any() else b
            if runs and a - runs[-1][1] < p.min_gap:
                runs[-1] = (runs[-1][0], b)
            elif b > a:
                runs.append((a, b))
        for a, b in runs:
            if b - a >= min(p.min_contact, T):
                out[a:b, f] = True
    return out


__all__ = ["ContactDetector", "ContactParams", "causal_contacts", "detect_contacts", "segments"]
