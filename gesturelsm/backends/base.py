"""What every backend is: its spec, the prepared speech it generates from, and one `generate` call.

A backend is one method with its loaded weights: ours (a flow/diffusion generator on our tokenizers,
`ours.py`) or the authors' (their converted networks and RVQ-VAEs, `authors.py`). The pipeline knows
backends only through this interface; the registry (`__init__.py`) says which exist and how each is
found in a checkpoint folder.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import numpy as np
import torch

from ..constants import Progress
from ..motion.sequence import FPS, MotionSequence
from .spec import MethodSpec


@dataclass
class SpeechInput:
    """Speech prepared once and reusable across methods, steps and seeds."""
    audio: np.ndarray                   # (N,) 16 kHz mono float32
    num_frames: int
    channels: torch.Tensor              # (2, N) envelope + onsets
    words: list | None                  # list[Word] used, or None (audio-only)
    word_features: torch.Tensor         # (T, 384)
    has_word: torch.Tensor              # (T,) bool
    text_mode: str                      # how the transcript was used, said to the user
    timings: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    transcript: str | None = None       # the automatic transcript's text when one was recognised and used
    # Frame counts at which the word features become final, in order (the recognition windows of an automatic English
    # transcript; empty otherwise): generation conditions its windows in groups that follow them, in both the one-shot
    # and the pipelined path, so that the two compute the same numbers.
    ready_points: tuple[int, ...] = ()
    # Pipelined speech (gesturelsm.pipelined.PendingWords): the words are still being recognised; `stream.wait(n)`
    # blocks until the word features of frames [0, n) are final. None: everything is final.
    stream: object | None = None
    # Stages (keys of `timings`) done before this speech was prepared, their times the ones spent then: the words
    # recognised at the upload by another process (the page's replicas), or remembered from an earlier request.
    earlier: tuple[str, ...] = ()

    @property
    def duration(self) -> float:
        return self.num_frames / FPS


@dataclass
class BackendOutput:
    motion: MotionSequence              # exactly speech.num_frames frames
    timings: dict[str, float]           # seconds per stage (sampling, decoding)
    warnings: list[str]                 # what the visitor should know about this backend's output


class Backend(Protocol):
    """One method with its weights, ready to generate."""
    spec: MethodSpec

    def generate(self, speech: SpeechInput, steps: int, cfg: float, seed: int,
                 progress: Progress | None = None) -> BackendOutput:
        """Motion for the prepared speech; settings are already checked against `spec`. `progress(f, msg)`
        with f in [0, 1]."""

    def edit(self, speech: SpeechInput, motion: MotionSequence, spec, steps: int, cfg: float, seed: int,
             progress: Progress | None = None):
        """Where `spec.inpainting`: `motion` (as long as the speech) with `spec` (motion.editing.EditSpec) regenerated
        in latent space, as a backends.inpainting.EditOutput (the decoded span around the regenerated latents)."""


class BackendKind(Protocol):
    """A registry line: a method's spec and how its checkpoint is found and loaded."""
    spec: MethodSpec

    def checkpoint(self, root: Path) -> Path:
        """The file this method's weights have in a checkpoint folder."""

    def root_of(self, file: Path) -> Path:
        """The checkpoint folder a file of this method lies in (where shared files such as tokenizers are)."""

    def load(self, file: Path, device: str | torch.device, shared: dict) -> Backend:
        """The backend from its checkpoint; `shared` caches what backends of one folder share (tokenizers)."""


__all__ = ["Backend", "BackendKind", "BackendOutput", "Progress", "SpeechInput"]
