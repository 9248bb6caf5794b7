"""Per-dimension z-score statistics, fitted on training data and stored inside every model file."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import torch

from ..errors import CheckpointError

STD_EPS = 1e-3  # dims with std below this (constant eye/jaw 6D entries) are only centred, not scaled


@dataclass
class Normalizer:
    mean: torch.Tensor  # (D,)
    std: torch.Tensor   # (D,), already guarded: never below STD_EPS

    @classmethod
    def fit(cls, x: torch.Tensor, eps: float = STD_EPS) -> "Normalizer":
        """x: (..., D) training features."""
        flat = x.reshape(-1, x.shape[-1]).double()
        mean, std = flat.mean(0), flat.std(0, unbiased=False)
        std = torch.where(std < eps, torch.ones_like(std), std)
        return cls(mean.float(), std.float())

    def _sel(self, columns: Sequence[int] | None, ref: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        m, s = (self.mean, self.std) if columns is None else (self.mean[list(columns)], self.std[list(columns)])
        return m.to(ref), s.to(ref)

    def normalize(self, x: torch.Tensor, columns: Sequence[int] | None = None) -> torch.Tensor:
        m, s = self._sel(columns, x)
        return (x - m) / s

    def denormalize(self, z: torch.Tensor, columns: Sequence[int] | None = None) -> torch.Tensor:
        m, s = self._sel(columns, z)
        return z * s + m

    def subset(self, columns: Sequence[int]) -> "Normalizer":
        return Normalizer(self.mean[list(columns)].clone(), self.std[list(columns)].clone())

    # stored as plain tensors so they go into a safetensors file next to the weights
    def state_dict(self, prefix: str = "norm.") -> dict[str, torch.Tensor]:
        return {prefix + "mean": self.mean.contiguous(), prefix + "std": self.std.contiguous()}

    @classmethod
    def from_state_dict(cls, sd: dict[str, torch.Tensor], prefix: str = "norm.") -> "Normalizer":
        try:
            mean, std = sd[prefix + "mean"].float(), sd[prefix + "std"].float()
        except KeyError as exc:
            raise CheckpointError(f"normalisation statistics {exc} missing from the model file") from None
        if (std <= 0).any():
            raise CheckpointError("normalisation std must be positive")
        return cls(mean, std)
