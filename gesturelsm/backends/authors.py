"""The authors' released models as backends (converted by `gesturelsm import-reference`): their speech encoder,
denoiser and sampler, their per-region RVQ-VAEs, run in our long-audio window loop (`reference.runner`).
They generate the body without the face: jaw and expressions stay neutral, which every result says.

Checkpoint folder layout: reference_rvq.safetensors (the RVQ-VAEs and statistics, shared) and
reference_<sampler>.safetensors per method.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import torch

from ..errors import CheckpointError
from ..reference.convert import load_generator, load_rvqs
from ..reference.model import ReferenceGenerator
from ..reference.runner import FACE_NOTE, LONG_AUDIO_NOTE, ReferenceBundle, generate_reference
from .base import BackendOutput, Progress, SpeechInput
from .spec import MethodSpec

RVQ_FILE = "reference_rvq.safetensors"


class AuthorsBackend:
    """One of the authors' generators with the shared RVQ-VAEs and its word vocabulary (CPU)."""

    def __init__(self, spec: MethodSpec, bundle: ReferenceBundle, model: ReferenceGenerator, vocab: dict[str, int]):
        self.spec, self.bundle, self.model, self.vocab = spec, bundle, model, vocab

    def generate(self, speech: SpeechInput, steps: int, cfg: float, seed: int,
                 progress: Progress | None = None) -> BackendOutput:
        t0 = time.perf_counter()
        _, motion = generate_reference(self.bundle, self.model, self.vocab, speech.audio, speech.num_frames,
                                       speech.words, steps, cfg, seed, progress)
        return BackendOutput(motion, {"sampling": time.perf_counter() - t0}, [FACE_NOTE, LONG_AUDIO_NOTE])


@dataclass(frozen=True)
class Authors:
    """Registry line of one of the authors' methods: its spec (their released settings) and its sampler's file."""
    spec: MethodSpec
    sampler: str                     # "shortcut" | "meanflow" | "diffusion": reference_<sampler>.safetensors

    def checkpoint(self, root: Path) -> Path:
        return root / f"reference_{self.sampler}.safetensors"

    def root_of(self, file: Path) -> Path:
        return file.parent

    def load(self, file: Path, device: str | torch.device, shared: dict) -> AuthorsBackend:
        root = self.root_of(file)
        if ("reference", root) not in shared:
            if not (root / RVQ_FILE).exists():
                raise CheckpointError(f"{file}: {RVQ_FILE} is missing beside it (write both with "
                                      "`gesturelsm import-reference`)")
            shared["reference", root] = ReferenceBundle(*load_rvqs(root / RVQ_FILE))
        return AuthorsBackend(self.spec, shared["reference", root], *load_generator(file))


__all__ = ["Authors", "AuthorsBackend", "RVQ_FILE"]
