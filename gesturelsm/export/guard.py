"""What every writer checks just before it writes (a guard at the writer, so that no path, today's or a future one,
can write a file that tools reject or misplay): the motion has frames, its frame rate is a finite positive number,
and every number written is finite; animation times increase strictly. Each problem is an InputError (one line)
and nothing is written."""
from __future__ import annotations

import numpy as np

from ..errors import InputError


def check_motion(seq, what: str = "the motion") -> None:
    """`seq` (a MotionSequence) can be written: frames, a usable frame rate, finite poses, translation, expressions
    and betas."""
    if seq.num_frames == 0:
        raise InputError(f"{what} has no frames; nothing is written")
    check_rate(seq.fps, what)
    for name in ("poses", "trans", "expressions", "betas"):
        finite(getattr(seq, name), f"{what}'s {name}")


def check_rate(fps, what: str = "the motion") -> float:
    try:
        rate = float(fps)
    except (TypeError, ValueError):
        raise InputError(f"{what}'s frame rate {fps!r} is not a number; nothing is written") from None
    if not np.isfinite(rate) or rate <= 0:
        raise InputError(f"{what}'s frame rate is {rate:g}; it must be a finite positive number; nothing is written")
    return rate


def finite(values, what: str) -> None:
    """Every value of `values` is a finite number (else InputError naming `what`)."""
    arr = np.asarray(values)
    if arr.dtype.kind in "fc" and not np.isfinite(arr).all():
        raise InputError(f"{what} hold NaN or infinite values; nothing is written")


def animation_times(frames: int, fps, what: str = "the motion") -> np.ndarray:
    """(frames,) float32 seconds of each frame, checked finite and strictly increasing (glTF requires it)."""
    times = (np.arange(frames) / check_rate(fps, what)).astype(np.float32)
    increasing(times, what)
    return times


def increasing(times, what: str = "the motion") -> None:
    t = np.asarray(times, np.float64)
    finite(t, f"{what}'s frame times")
    if len(t) > 1 and not (np.diff(t) > 0).all():
        raise InputError(f"{what}'s frame times do not increase; nothing is written")


__all__ = ["animation_times", "check_motion", "check_rate", "finite", "increasing"]
