"""RVQ-VAE for one body region: 1D-conv encoder (x4 downsampling, dilated residual blocks), residual VQ,
mirrored decoder with nearest-neighbour upsampling.

Shapes: motion x is (B, T, C) normalised region features at 30 fps; latents are (B, T/4, code_dim).
The generator works on `encode(x)` (continuous, before quantisation), scaled to unit std per region;
`decode` re-quantises through all layers, then decodes.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import torch
import torch.nn as nn
import torch.nn.functional as F

from ..checkpoint import config_from_dict, load_checkpoint, save_checkpoint
from ..errors import CheckpointError
from ..kernels import accelerate
from ..motion.normalize import Normalizer
from .config import TokenizerConfig
from .quantizer import QuantizedResult, ResidualVQ, quantize_stacked, same_shape

KIND = "gesturelsm.tokenizer"


class ResBlock(nn.Module):
    def __init__(self, width: int, dilation: int, dropout: float = 0.0):
        super().__init__()
        self.conv1 = nn.Conv1d(width, width, 3, padding=dilation, dilation=dilation)
        self.conv2 = nn.Conv1d(width, width, 1)
        self.dropout = nn.Dropout(dropout)

    def forward(self, x: torch.Tensor) -> torch.Tensor:  # (B, C, T)
        return x + self.conv2(self.dropout(F.relu(self.conv1(F.relu(x)))))


def resnet1d(width: int, depth: int, growth: int, reverse: bool, dropout: float = 0.0) -> nn.Sequential:
    dil = [growth ** i for i in range(depth)][::-1]  # e.g. 9, 3, 1
    if reverse:
        dil = dil[::-1]
    return nn.Sequential(*[ResBlock(width, d, dropout) for d in dil])


class Encoder(nn.Module):
    def __init__(self, c: TokenizerConfig):
        super().__init__()
        layers: list[nn.Module] = [nn.Conv1d(c.in_dim, c.width, 3, padding=1), nn.ReLU()]
        for _ in range(c.down_t):
            layers += [nn.Conv1d(c.width, c.width, 4, stride=2, padding=1),
                       resnet1d(c.width, c.res_depth, c.dilation_growth, reverse=False, dropout=c.dropout)]
        layers.append(nn.Conv1d(c.width, c.code_dim, 3, padding=1))
        self.net = nn.Sequential(*layers)
        # linear path: each latent frame also gets a linear projection of its own block of 4 frames
        # (what PCA would do); the conv stack learns the non-linear rest. Generalises far better on small data.
        self.skip = nn.Conv1d(c.in_dim, c.code_dim, c.downsample, stride=c.downsample) if c.linear_skip else None

    def forward(self, x: torch.Tensor) -> torch.Tensor:  # (B, C_in, T) -> (B, D, T/4)
        z = self.net(x)
        return z + self.skip(x) if self.skip is not None else z


class Decoder(nn.Module):
    def __init__(self, c: TokenizerConfig):
        super().__init__()
        layers: list[nn.Module] = [nn.Conv1d(c.code_dim, c.width, 3, padding=1), nn.ReLU()]
        for _ in range(c.down_t):
            layers += [resnet1d(c.width, c.res_depth, c.dilation_growth, reverse=True, dropout=c.dropout),
                       nn.Upsample(scale_factor=2, mode="nearest"),
                       nn.Conv1d(c.width, c.width, 3, padding=1)]
        layers += [nn.Conv1d(c.width, c.width, 3, padding=1), nn.ReLU(),
                   nn.Conv1d(c.width, c.in_dim, 3, padding=1)]
        self.net = nn.Sequential(*layers)
        # linear path back: interpolate latents linearly to 30 fps, then a k3 conv. (A transposed conv with
        # kernel = stride = 4 made every 4-frame block its own linear function: visible steps, 6x the jitter.)
        self.skip = (nn.Sequential(nn.Upsample(scale_factor=c.downsample, mode="linear", align_corners=False),
                                   nn.Conv1d(c.code_dim, c.in_dim, 3, padding=1))
                     if c.linear_skip else None)

    def forward(self, z: torch.Tensor) -> torch.Tensor:  # (B, D, T/4) -> (B, C_in, T)
        y = self.net(z)
        return y + self.skip(z) if self.skip is not None else y


@dataclass
class TokenizerOutput:
    recon: torch.Tensor          # (B, T, C) reconstruction (normalised space)
    latents: torch.Tensor        # (B, T/4, D) encoder output before quantisation
    quant: QuantizedResult       # flattened over (B * T/4)
    loss: torch.Tensor           # total training loss
    recon_loss: torch.Tensor


class RVQVAE(nn.Module):
    def __init__(self, config: TokenizerConfig, region: str = "", normalizer: Normalizer | None = None):
        super().__init__()
        self.config, self.region = config, region
        self.encoder = Encoder(config)
        self.decoder = Decoder(config)
        self.rvq = ResidualVQ(config.num_quantizers, config.codebook_size, config.code_dim, config.ema_decay,
                              config.dead_code_threshold, config.quantizer_dropout, config.groups)
        # per-dimension statistics of this region's raw features (identity until fitted)
        self.normalizer = normalizer or Normalizer(torch.zeros(config.in_dim), torch.ones(config.in_dim))

    # ---- the four operations ------------------------------------------------------------------------
    def encode(self, x: torch.Tensor) -> torch.Tensor:
        """(B, T, C) normalised -> (B, T/4, D) continuous latents. T must be a multiple of 4."""
        self._check_len(x.shape[1])
        return self.encoder(x.transpose(1, 2)).transpose(1, 2)

    def quantize(self, z: torch.Tensor, num_layers: int | None = None) -> QuantizedResult:
        """(B, t, D) -> result over flattened (B*t, D)."""
        return self.rvq(z.reshape(-1, z.shape[-1]), num_layers)

    def decode(self, zq: torch.Tensor) -> torch.Tensor:
        """(B, t, D) quantised latents -> (B, 4t, C) normalised features."""
        return self.decoder(zq.transpose(1, 2)).transpose(1, 2)

    def codes_to_quantized(self, codes: torch.Tensor) -> torch.Tensor:
        """(B, t, L, G) codes -> (B, t, D)."""
        B, t = codes.shape[:2]
        return self.rvq.codes_to_quantized(codes.reshape(B * t, *codes.shape[2:])).reshape(B, t, -1)

    def decode_latents(self, z: torch.Tensor, num_layers: int | None = None) -> torch.Tensor:
        """Continuous latents (e.g. generated, un-scaled) -> re-quantised -> decoded (B, 4t, C)."""
        q = self.quantize(z, num_layers)
        return self.decode(q.quantized.reshape(z.shape))

    def forward(self, x: torch.Tensor, num_layers: int | None = None) -> TokenizerOutput:
        z = self.encode(x)
        q = self.quantize(z, num_layers)
        recon = self.decode(q.quantized.reshape(z.shape))
        rec = F.smooth_l1_loss(recon, x)
        loss = self.reconstruction_loss(recon, x) + self.config.commitment * q.commit_loss
        return TokenizerOutput(recon, z, q, loss, rec)

    def reconstruction_loss(self, recon: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
        """SmoothL1 on the features (B, T, C), plus the config's terms on their first and second differences along
        time: velocity (SmoothL1) and acceleration (L1; the decoders' frame-to-frame jitter lives there: an
        error of the same size as the real motion's own second difference before `accel_weight` was used)."""
        loss = F.smooth_l1_loss(recon, x)
        if self.config.vel_weight > 0:
            loss = loss + self.config.vel_weight * F.smooth_l1_loss(recon.diff(dim=1), x.diff(dim=1))
        if self.config.accel_weight > 0:
            loss = loss + self.config.accel_weight * (recon.diff(n=2, dim=1) - x.diff(n=2, dim=1)).abs().mean()
        return loss

    def _check_len(self, T: int) -> None:
        if T % self.config.downsample:
            raise ValueError(f"sequence length {T} must be a multiple of {self.config.downsample}")

    # ---- files -------------------------------------------------------------------------------------
    def save(self, path: str | Path, half: bool = False, meta: dict | None = None) -> Path:
        sd = {k: v for k, v in self.state_dict().items() if not (half and _is_training_buffer(k))}
        sd.update(self.normalizer.state_dict())
        return save_checkpoint(path, sd, KIND, self.config, {"region": self.region, **(meta or {})}, half=half)

    @classmethod
    def load(cls, path: str | Path) -> "RVQVAE":
        """A saved tokenizer, in eval mode, with the fast kernels swapped in (kernels.accelerate: the same
        function; training it further takes the default ops)."""
        tensors, meta = load_checkpoint(path, KIND)
        config = config_from_dict(TokenizerConfig, meta["config"])
        model = cls(config, meta.get("region", ""), Normalizer.from_state_dict(tensors))
        weights = {k: v for k, v in tensors.items() if not k.startswith("norm.")}
        missing, unexpected = model.load_state_dict(weights, strict=False)
        if unexpected or [m for m in missing if not _is_training_buffer(m)]:
            raise CheckpointError(f"{path}: weights do not match the config (missing {missing}, "
                                  f"unexpected {unexpected})")
        for layer in model.rvq.quantizers:  # a shipped (inference-only) file has no EMA state
            layer.initted.fill_(True)
        return accelerate(model.eval())


def quantize_regions(tokenizers: list[RVQVAE], z: torch.Tensor) -> list[torch.Tensor]:
    """(R, n, D) latents of R regions -> R re-quantised latents (reshape each to (1, n, D)), all regions in one
    stacked pass when their quantizers have the same shape (`quantize_stacked`: the same codes as each alone)."""
    if same_shape([t.rvq for t in tokenizers]):
        return quantize_stacked([t.rvq for t in tokenizers], list(z))
    return [t.quantize(z[r:r + 1]).quantized for r, t in enumerate(tokenizers)]


def _is_training_buffer(name: str) -> bool:
    """EMA statistics only needed to keep training; shipped files leave them out."""
    return name.endswith(("cluster_size", "embed_sum", "initted"))
