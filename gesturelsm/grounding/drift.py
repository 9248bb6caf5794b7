"""Slow drift out of the root's horizontal path, keeping weight shifts and small steps: the path minus its own
low-passed version (a one-pole low-pass of time constant `seconds`: movements slower than that are drift), then
held softly inside a standing area of radius `radius` (a distance r from the area's centre becomes
radius * tanh(r / radius): unchanged when small, never beyond the radius).

- offline (`remove_drift`): the low-pass runs forward and backward (zero phase, no lag), so a steady walk is
  removed entirely; the area's centre is the path's mean.
- causal (`DriftRemover`): the same one-pole filter forward only, one frame (or chunk) at a time; a steady walk
  leaves a constant offset of speed x `seconds`; the area's centre is where the path started.

`smooth` / `OnePole` are the same filter for any signal (grounding smooths the root's height correction with them).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import filtfilt, lfilter

from ..constants import FPS


@dataclass(frozen=True)
class DriftParams:
    seconds: float = 4.0            # slower than this is drift
    radius: float = 0.5             # m: the standing area's radius (the real speaker's path spans 1.27 m)


def pole(seconds: float, fps: int = FPS) -> float:
    """The one-pole coefficient a of y_t = a y_(t-1) + (1 - a) x_t for a time constant of `seconds`."""
    return float(np.exp(-1.0 / max(seconds * fps, 1e-9)))


def smooth(x: np.ndarray, seconds: float, fps: int = FPS) -> np.ndarray:
    """Zero-phase one-pole low-pass of x (T, ...) along time: a straight line through the first and last samples
    passes unchanged (a steady trend has no lag and no edge effect), the rest is filtered forward and backward with
    its edges extended by odd reflection."""
    x = np.asarray(x, np.float64)
    if seconds <= 0 or len(x) < 2:
        return x.copy()
    a = pole(seconds, fps)
    pad = int(min(len(x) - 1, 6 * seconds * fps))
    u = (np.arange(len(x)) / (len(x) - 1)).reshape((-1,) + (1,) * (x.ndim - 1))
    line = x[:1] + (x[-1:] - x[:1]) * u                     # the line through the ends passes unchanged
    return line + filtfilt([1 - a], [1.0, -a], x - line, axis=0, padtype="odd" if pad > 0 else None, padlen=pad)


class OnePole:
    """The causal one-pole low-pass, one sample (any shape) at a time; starts at its first input."""

    def __init__(self, seconds: float, fps: int = FPS):
        self.a = pole(seconds, fps)
        self.y: np.ndarray | None = None

    def step(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, np.float64)
        self.y = x.copy() if self.y is None else self.a * self.y + (1 - self.a) * x
        return self.y.copy()

    def run(self, x: np.ndarray) -> np.ndarray:
        """A chunk (T, ...) along time, continuing from the state; equal to `step` frame by frame."""
        x = np.asarray(x, np.float64)
        if len(x) == 0:
            return x.copy()
        if self.y is None:
            self.y = x[0].copy()
        y, _ = lfilter([1 - self.a], [1.0, -self.a], x, axis=0, zi=(self.a * self.y)[None])
        self.y = y[-1].copy()
        return y


def limit(xz: np.ndarray, center: np.ndarray, radius: float) -> np.ndarray:
    """Points (..., 2) pulled softly inside a circle: distance r from `center` becomes radius * tanh(r / radius)."""
    d = xz - center
    r = np.linalg.norm(d, axis=-1, keepdims=True)
    scale = np.where(r > 1e-9, radius * np.tanh(r / max(radius, 1e-9)) / np.maximum(r, 1e-9), 1.0)
    return center + d * scale


def remove_drift(xz: np.ndarray, params: DriftParams = DriftParams(), fps: int = FPS) -> np.ndarray:
    """(T, 2) horizontal root path -> the same path without its slow drift, inside the standing area."""
    xz = np.asarray(xz, np.float64)
    if len(xz) < 2:
        return xz.copy()
    low = smooth(xz, params.seconds, fps)
    out = xz - (low - low[:1])
    return limit(out, out.mean(0), params.radius)


class DriftRemover:
    """The causal `remove_drift`: feed the path in chunks (T, 2), get each chunk back without drift."""

    def __init__(self, params: DriftParams = DriftParams(), fps: int = FPS):
        self.params = params
        self.low = OnePole(params.seconds, fps)
        self.start: np.ndarray | None = None

    def run(self, xz: np.ndarray) -> np.ndarray:
        xz = np.asarray(xz, np.float64)
        if len(xz) == 0:
            return xz.copy()
        if self.start is None:
            self.start = xz[0].copy()
        out = xz - (self.low.run(xz) - self.start)
        return limit(out, self.start, self.params.radius)


__all__ = ["DriftParams", "DriftRemover", "OnePole", "limit", "pole", "remove_drift", "smooth"]
