"""A released generator (speech encoder + denoiser + its sampler settings) and the three RVQ-VAEs."""
from __future__ import annotations

import torch
import torch.nn as nn

from .config import GeneratorConfig
from .denoiser import ReferenceDenoiser
from .samplers import HOLDS_KNOWN, SAMPLERS
from .speech import ReferenceSpeechEncoder


class ReferenceGenerator(nn.Module):
    def __init__(self, cfg: GeneratorConfig):
        super().__init__()
        self.cfg = cfg
        self.speech = ReferenceSpeechEncoder(cfg)
        self.denoiser = ReferenceDenoiser(cfg)

    @torch.no_grad()
    def sample(self, audio: torch.Tensor, words: torch.Tensor, seed: torch.Tensor, noise: torch.Tensor,
               steps: int | None = None, cfg_scale: float | None = None,
               hold: tuple[torch.Tensor, torch.Tensor] | None = None) -> torch.Tensor:
        """One window: audio (B, S, 2), words (B, frames), seed (B, 4, R*Cin), noise (B, R*Cin, N) -> latents.
        `hold`: (known latents, mask) like the noise, held while sampling (the shortcut and diffusion samplers)."""
        cfg = self.cfg
        if hold is not None and cfg.method not in HOLDS_KNOWN:
            raise ValueError(f"the {cfg.method} sampler cannot hold known latents")
        steps = cfg.steps if steps is None else steps
        scale = cfg.cfg_scale if cfg_scale is None else cfg_scale
        speech = self.speech(audio, words)                                       # (B, N, R*C)
        fn = SAMPLERS[cfg.method]
        if cfg.method == "diffusion":
            return fn(self.denoiser, noise, speech, seed, steps, scale, cfg.train_steps, hold=hold)
        if hold is not None:
            return fn(self.denoiser, noise, speech, seed, steps, scale, hold)
        return fn(self.denoiser, noise, speech, seed, steps, scale)
