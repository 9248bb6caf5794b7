"""The authors' released models as backends (converted by `gesturelsm import-reference`): their speech encoder,
denoiser and sampler, their per-region RVQ-VAEs, run in our long-audio window loop (`reference.runner`).
They generate the body without the face: jaw and expressions stay neutral, which every result says.

Checkpoint folder layout: reference_rvq.safetensors (the RVQ-VAEs and statistics, shared) and
reference_<sampler>.safetensors per method.
"""
from __future__ import annotations

import time

import torch

from ..errors import InputError
from ..flows import Held
from ..motion.editing import EditSpec, Keyframe
from ..motion.regions import REGIONS as MOTION_REGIONS
from ..motion.sequence import MotionSequence
from ..reference.config import LATENT_SCALE, REGIONS
from ..reference.model import ReferenceGenerator
from ..reference.runner import FACE_NOTE, LONG_AUDIO_NOTE, ReferenceBundle, generate_reference
from .base import BackendOutput, Progress, SpeechInput
from .inpainting import EditOutput, decoded_span, held_latents, middle_latent, static_clip
from .spec import MethodSpec



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

    @torch.no_grad()
    def edit(self, speech: SpeechInput, motion: MotionSequence, spec: EditSpec, steps: int, cfg: float, seed: int,
             progress: Progress | None = None) -> EditOutput:
        """`spec` regenerated with the input's latents (their RVQ encoders) held (backends/inpainting.py)."""
        if not self.spec.inpainting:
            raise InputError(f"{self.spec.key}'s sampler cannot hold known latents, so it cannot edit a motion")
        t0 = time.perf_counter()
        known = self.bundle.encode(motion.to_features())[0]                        # (L, R * d)
        L, R = known.shape[0], len(REGIONS)
        held = held_latents(spec, REGIONS, known.reshape(L, R, -1).permute(1, 0, 2), self._pose_latent)
        flat = lambda a: a.expand_as(held.known).permute(1, 0, 2).reshape(1, L, -1)  # noqa: E731  (R, L, d) -> (1, L, R d)
        timings = {"encoding": time.perf_counter() - t0}
        t1 = time.perf_counter()
        lat, _ = generate_reference(self.bundle, self.model, self.vocab, speech.audio, speech.num_frames, speech.words,
                                    steps, cfg, seed, progress, held=Held(flat(held.known), flat(held.mask)))
        timings["sampling"] = time.perf_counter() - t1
        t2 = time.perf_counter()
        lo, hi = decoded_span(spec, L)
        span = self.bundle.decode(lat[:, lo:hi], min(motion.num_frames, 4 * hi) - 4 * lo)
        timings["decoding"] = time.perf_counter() - t2
        return EditOutput(span, 4 * lo, timings, [])

    def _pose_latent(self, key: Keyframe, region: str) -> torch.Tensor:
        """(d,) generator latent of `region` holding the keyframe's pose."""
        x = static_clip(key.pose).to_features()[:, list(MOTION_REGIONS[region].columns)]
        return middle_latent(self.bundle.rvqs[region].encode(self.bundle.normalise(region, x)[None]) / LATENT_SCALE)


__all__ = ["AuthorsBackend"]
