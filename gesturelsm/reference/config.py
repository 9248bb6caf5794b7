"""Frozen configs of the reference models; `paper` sizes are those of the released files."""
from __future__ import annotations

from dataclasses import dataclass

REGIONS: tuple[str, ...] = ("upper", "hands", "lower")
REGION_DIMS: dict[str, int] = {"upper": 78, "hands": 180, "lower": 57}  # 6D rotations (+ 3 trans for lower)
LATENT_SCALE = 5.0  # generator latents = RVQ encoder output / 5
SAMPLES_PER_FRAME = 16000 // 30  # 533: the reference slices audio with integer samples per frame


@dataclass(frozen=True)
class RVQConfig:
    """One region's RVQ-VAE (encoder -> 6 residual codebooks -> decoder), temporal downsampling 2**down."""
    input_dim: int = 78
    width: int = 512
    code_dim: int = 128
    num_codes: int = 1024
    num_quantizers: int = 6
    down: int = 2
    depth: int = 3
    dilation_growth: int = 3


@dataclass(frozen=True)
class GeneratorConfig:
    """Speech encoder + denoiser of GestureLSM / MeanFlow / diffusion (same network, different samplers)."""
    input_dim: int = 128          # latent channels per region (RVQ code_dim)
    latent_dim: int = 256         # token width
    ff_size: int = 1024
    num_layers: int = 8           # spatial-temporal blocks
    num_cross: int = 3            # cross-attention blocks at width 3 * latent_dim
    num_heads: int = 4
    regions: int = 3
    seq_len: int = 32             # latent frames per window
    seed_frames: int = 4          # latent frames of the previous window fed as seed
    audio_dim: int = 256          # speech encoder width
    vocab_size: int = 11195
    word_dim: int = 300
    frames: int = 128             # 30 fps frames per window
    # sampler
    method: str = "shortcut"      # shortcut | meanflow | diffusion
    steps: int = 2
    cfg_scale: float = 2.0
    train_steps: int = 1000       # diffusion only


PAPER_RVQ = {r: RVQConfig(input_dim=d) for r, d in REGION_DIMS.items()}
# released configs (configs_new/*.yaml at fe124e0): steps and guidance used by their test code
RELEASED_SAMPLERS: dict[str, dict] = {
    "shortcut": {"steps": 2, "cfg_scale": 2.0},
    "meanflow": {"steps": 1, "cfg_scale": 1.0},
    "diffusion": {"steps": 20, "cfg_scale": 1.5},
}
