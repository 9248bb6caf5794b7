"""The first body's motion while it is still being made: the raw decoded windows of a generation, as they come.

A `Preview` listens to the generation on its thread (generator/sampling.py `window_previews`): each window the
sampler makes final is decoded and the motion so far (from frame 0, growing) is kept here, with a version that counts
the updates, under the condition of the run that makes the methods (serve/ahead.py `Run`), so that whoever reads the
run wakes for a preview as for a method made. It is the motion as decoded, before post-processing (stand in place,
smoothing, feet on the ground are applied to the whole motion once it is made): the page shows it until the method's
finished motion replaces it (docs/WEBAPP.md). Once the run has made a method with motion, previews stop (`stop`).
"""
from __future__ import annotations

import threading

import torch

from ..motion.regions import join_regions
from ..motion.sequence import MotionSequence


class Preview:
    """The latest raw motion of the method being made (None before its first window), `version` its updates."""

    def __init__(self, cond: threading.Condition | None = None, wanted: bool = True):
        self.cond = cond or threading.Condition()
        self.motion: MotionSequence | None = None
        self.version = 0
        self.stopped = not wanted

    def wanted(self) -> bool:
        return not self.stopped

    def show(self, parts: dict[str, torch.Tensor]) -> None:
        seq = MotionSequence.from_features(join_regions({k: v.cpu() for k, v in parts.items()}))
        with self.cond:
            if self.stopped:
                return
            self.motion, self.version = seq, self.version + 1
            self.cond.notify_all()

    def stop(self) -> None:
        """No more previews: a method's finished motion is in."""
        with self.cond:
            self.stopped = True
            self.cond.notify_all()
