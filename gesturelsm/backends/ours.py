"""Our methods as backends: a generator of the flows registry (GestureLSM's shortcut flow, rectified flow,
DDIM) on our per-region tokenizers, all regions including the face.

Checkpoint folder layout: tokenizer/<region>.safetensors (shared by the folder's generators) and
generator/<method>.safetensors.
"""
from __future__ import annotations

import time
from pathlib import Path

import torch

from ..errors import CheckpointError
from ..generator.model import GestureGenerator
from ..generator.data import encode_regions
from ..generator.sampling import decode_latents, generate_latents, window_decoder
from ..motion.editing import EditSpec, Keyframe
from ..motion.regions import GENERATED_REGIONS, REGIONS, join_regions
from ..motion.sequence import MotionSequence
from ..tokenizer.model import RVQVAE
from .base import BackendOutput, Progress, SpeechInput
from .inpainting import EditOutput, decoded_span, held_latents, middle_latent, static_clip
from .spec import MethodSpec


def load_tokenizers(folder: Path, device: str | torch.device = "cpu") -> dict[str, RVQVAE]:
    missing = [r for r in GENERATED_REGIONS if not (folder / f"{r}.safetensors").exists()]
    if missing:
        raise CheckpointError(f"{folder}: missing tokenizer checkpoints for {', '.join(missing)}")
    return {r: RVQVAE.load(folder / f"{r}.safetensors").to(device) for r in GENERATED_REGIONS}


class FlowBackend:
    """One of our generators with the tokenizers that decode its latents."""

    def __init__(self, spec: MethodSpec, model: GestureGenerator, tokenizers: dict[str, RVQVAE]):
        if tuple(model.config.regions) != tuple(tokenizers):
            raise CheckpointError(f"generator regions {model.config.regions} do not match tokenizers "
                                  f"{tuple(tokenizers)}")
        self.spec, self.model, self.tokenizers = spec, model, tokenizers

    @torch.no_grad()
    def generate(self, speech: SpeechInput, steps: int, cfg: float, seed: int,
                 progress: Progress | None = None) -> BackendOutput:
        t0 = time.perf_counter()
        lat = generate_latents(self.model, speech.channels, speech.word_features, speech.has_word,
                               speech.words is not None, speech.num_frames, steps, cfg, seed, progress,
                               ready_points=speech.ready_points,
                               wait=speech.stream.wait if speech.stream is not None else None,
                               on_window=window_decoder(self.tokenizers, speech.num_frames))   # previews, if asked
        timings = {"sampling": time.perf_counter() - t0}
        t1 = time.perf_counter()
        device = next(self.model.parameters()).device
        parts = decode_latents(self.tokenizers, lat.to(device), speech.num_frames)
        motion = MotionSequence.from_features(join_regions({k: v.cpu() for k, v in parts.items()}))
        timings["decoding"] = time.perf_counter() - t1
        return BackendOutput(motion, timings, [])

    @torch.no_grad()
    def edit(self, speech: SpeechInput, motion: MotionSequence, spec: EditSpec, steps: int, cfg: float, seed: int,
             progress: Progress | None = None) -> EditOutput:
        """`spec` regenerated with the input's latents held (backends/inpainting.py)."""
        t0 = time.perf_counter()
        device = next(self.model.parameters()).device
        known = encode_regions(self.tokenizers, motion.to_features().to(device)).cpu()       # (R, L, D) un-scaled
        held = held_latents(spec, tuple(self.tokenizers), known, self._pose_latent)
        timings = {"encoding": time.perf_counter() - t0}
        t1 = time.perf_counter()
        lat = generate_latents(self.model, speech.channels, speech.word_features, speech.has_word,
                               speech.words is not None, speech.num_frames, steps, cfg, seed, progress, held=held,
                               ready_points=speech.ready_points,
                               wait=speech.stream.wait if speech.stream is not None else None)
        timings["sampling"] = time.perf_counter() - t1
        t2 = time.perf_counter()
        lo, hi = decoded_span(spec, lat.shape[1])
        n = min(motion.num_frames, 4 * hi) - 4 * lo
        parts = decode_latents(self.tokenizers, lat[:, lo:hi].to(device), n)
        span = MotionSequence.from_features(join_regions({k: v.cpu() for k, v in parts.items()}))
        timings["decoding"] = time.perf_counter() - t2
        return EditOutput(span, 4 * lo, timings, [])

    def _pose_latent(self, key: Keyframe, region: str) -> torch.Tensor:
        """(D,) un-scaled latent of `region` holding the keyframe's pose."""
        tok = self.tokenizers[region]
        x = static_clip(key.pose).to_features()[:, list(REGIONS[region].columns)]
        device = next(tok.parameters()).device
        return middle_latent(tok.encode(tok.normalizer.normalize(x.to(device))[None])).cpu()


__all__ = ["FlowBackend", "load_tokenizers"]
