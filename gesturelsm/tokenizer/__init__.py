"""Per-region RVQ-VAE motion tokenizers."""
from .config import PRESETS, TokenizerConfig, preset
from .model import RVQVAE, TokenizerOutput
from .quantizer import QuantizedResult, ResidualVQ

__all__ = ["PRESETS", "TokenizerConfig", "preset", "RVQVAE", "TokenizerOutput", "QuantizedResult", "ResidualVQ"]
