"""Tokenizer (RVQ-VAE) configuration and named presets."""
from __future__ import annotations

from dataclasses import dataclass, replace

from ..errors import InputError


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
    groups: int = 1                  # >1: grouped RVQ, each layer has `groups` codebooks of code_dim/groups
    ema_decay: float = 0.99
    commitment: float = 0.02
    quantizer_dropout: float = 0.2   # p of keeping only the first k ~ U{1..num_quantizers} layers
    dead_code_threshold: float = 1.0  # EMA count below which a code is re-initialised from the batch
    vel_weight: float = 0.0          # extra SmoothL1 on frame-to-frame velocity (0 = paper)
    accel_weight: float = 0.0        # extra L1 on the second difference (frame-to-frame jitter; 0 = paper)
    linear_skip: bool = False        # add a linear path: strided block projection in / its transpose out
    dropout: float = 0.0             # dropout inside residual blocks

    @property
    def downsample(self) -> int:
        return 2 ** self.down_t


PRESETS: dict[str, TokenizerConfig] = {
    # tests: a few channels, small codebooks
    "tiny": TokenizerConfig(width=32, code_dim=16, res_depth=2, num_quantizers=3, codebook_size=32, groups=2),
    # the reference's sizes (docs/AUTHORS-CODE.md): 512 channels, 6 x 1024 x 128
    "paper": TokenizerConfig(),
    # what we ship: narrower convs and smaller codebooks (one speaker's data cannot use 1024 codes),
    # same latent size as the paper so the generator keeps its shape
    # same latent size as the paper so the generator keeps its shape; grouped codebooks (32 x 4 dims) and a
    # linear path, because held-out poses of one speaker's minute of motion are otherwise far from every
    # code (measured: 5.5 deg held-out upper-body error with plain 6 x 256 RVQ even on a perfect linear
    # encoder, 0.55 deg with 32 groups of 64 codes; see the tokenizer note in assets/MODEL_CARD.md)
    "small": TokenizerConfig(width=64, code_dim=128, num_quantizers=6, codebook_size=64, groups=32,
                             vel_weight=0.5, linear_skip=True, dropout=0.1),
}


def preset(name: str, in_dim: int) -> TokenizerConfig:
    if name not in PRESETS:
        raise InputError(f"unknown tokenizer preset {name!r}; choose from {', '.join(PRESETS)}")
    return replace(PRESETS[name], in_dim=in_dim)
