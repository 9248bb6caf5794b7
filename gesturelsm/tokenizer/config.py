"""Tokenizer (RVQ-VAE) configuration and named presets."""
from __future__ import annotations

from dataclasses import dataclass, replace


@dataclass(frozen=True)
class TokenizerConfig:
    in_dim: int = 78                 # region feature dims (set per region)
    width: int = 512                 # conv channels
    code_dim: int = 128              # latent / code dimension
    down_t: int = 2                  # number of x2 temporal downsamplings (2 -> x4: 30 fps -> 7.5 Hz)
    res_depth: int = 3               # residual blocks per resolution
    dilation_growth: int = 3         # dilations 9, 3, 1 (encoder) / 1, 3, 9 (decoder)
    num_quantizers: int = 6
    codebook_size: int = 1024
    ema_decay: float = 0.99
    commitment: float = 0.02
    quantizer_dropout: float = 0.2   # p of keeping only the first k ~ U{1..num_quantizers} layers
    dead_code_threshold: float = 1.0  # EMA count below which a code is re-initialised from the batch
    vel_weight: float = 0.0          # extra SmoothL1 on frame-to-frame velocity (0 = paper)
    latent_scale: float = 0.2        # the generator sees encoder output x latent_scale (paper: 1/5)

    @property
    def downsample(self) -> int:
        return 2 ** self.down_t


PRESETS: dict[str, TokenizerConfig] = {
    # tests: a few channels, small codebooks
    "tiny": TokenizerConfig(width=32, code_dim=16, res_depth=2, num_quantizers=3, codebook_size=32),
    # the reference's sizes (METHOD-FACTS): 512 channels, 6 x 1024 x 128
    "paper": TokenizerConfig(),
    # what we ship: narrower convs and smaller codebooks (one speaker's data cannot use 1024 codes),
    # same latent size as the paper so the generator keeps its shape
    "small": TokenizerConfig(width=128, code_dim=128, num_quantizers=6, codebook_size=256, vel_weight=0.5),
}


def preset(name: str, in_dim: int) -> TokenizerConfig:
    if name not in PRESETS:
        raise ValueError(f"unknown tokenizer preset {name!r}; choose from {', '.join(PRESETS)}")
    return replace(PRESETS[name], in_dim=in_dim)
