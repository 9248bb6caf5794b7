"""The module swap: `accelerate(model)` puts drop-in subclasses into a model, in place, that take the fast paths of
ops.py where they are measured faster (same parameter tensors, same state_dict keys), and `faster_version_of`
registers a model's own faster blocks (the same function with less arithmetic)."""
from __future__ import annotations

from typing import Callable, TypeVar

import torch
import torch.nn as nn
import torch.nn.functional as F

from .choice import taken
from .ops import WeightsCache, bucket, channels_last_1d, fast_path, linear, onednn_enabled


class LinearGELU(nn.Linear):
    """nn.Linear followed by the exact (erf) GELU, as one module: the same parameters and state_dict keys as an
    nn.Linear, so a model can declare a hidden layer whose activation `accelerate` fuses into the product."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return F.gelu(F.linear(x, self.weight, self.bias))


class FastLinear(nn.Linear):
    """nn.Linear through `linear` (oneDNN where measured faster, else exactly F.linear); what `accelerate` makes of
    one."""
    fused_gelu = False

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return linear(x, self.weight, self.bias, gelu=self.fused_gelu)


class FastLinearGELU(FastLinear, LinearGELU):
    """LinearGELU through `linear(..., gelu=True)`: product and GELU in one oneDNN call where
    measured faster (else exactly LinearGELU)."""
    fused_gelu = True

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return FastLinear.forward(self, x)


class FastConv1d(nn.Conv1d):
    """nn.Conv1d run as a (1 x k) 2D convolution on channels-last tensors (oneDNN) when no gradient is recorded,
    the fast path is on and that layout is measured faster for this layer at this input length (the first batch
    row of a call is timed both ways, once per length rounded up to a power of two); otherwise exactly
    nn.Conv1d. Its output is then a (B, C, T) view of channels-last memory, which the next such convolution takes
    without a copy. The channels-last weight is kept until the weight changes."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if (not fast_path() or x.dim() != 3 or x.dtype != torch.float32 or x.device.type != "cpu"
                or not onednn_enabled()):
            return super().forward(x)
        key = (f"{self.in_channels}->{self.out_channels}", f"k{self.kernel_size[0]}", f"stride {self.stride[0]}",
               f"padding {self.padding[0]}", f"dilation {self.dilation[0]}", f"groups {self.groups}",
               f"length {bucket(x.shape[-1])}")
        if not taken("conv", key, lambda: (lambda: super(FastConv1d, self).forward(x[:1]),
                                           lambda: self._channels_last(x[:1]))):
            return super().forward(x)
        return self._channels_last(x)

    def _channels_last(self, x: torch.Tensor) -> torch.Tensor:
        cache = self.__dict__.setdefault("_kernels_cache", WeightsCache())
        w = cache.get("w", [self.weight], lambda: self.weight.detach()[:, :, None].contiguous(
            memory_format=torch.channels_last))
        y = F.conv2d(channels_last_1d(x), w, self.bias, (1, self.stride[0]), (0, self.padding[0]),  # type: ignore[index]
                     (1, self.dilation[0]), self.groups)
        return y[:, :, 0]


def _conv_swappable(m: nn.Module) -> bool:
    return (type(m) is nn.Conv1d and m.padding_mode == "zeros" and isinstance(m.padding, tuple))


def _fuse_gelu_pairs(seq: nn.Sequential) -> None:
    """Linear (or FastLinear) directly followed by an exact GELU: the product takes the GELU, the GELU becomes an
    nn.Identity (neither has parameters of its own to lose, so state_dict keys stay)."""
    keys = list(seq._modules)
    for a, b in zip(keys, keys[1:]):
        lin_m, act = seq._modules[a], seq._modules[b]
        if type(lin_m) in (nn.Linear, FastLinear) and type(act) is nn.GELU and act.approximate == "none":
            lin_m.__class__ = FastLinearGELU
            seq._modules[b] = nn.Identity()


M = TypeVar("M", bound=nn.Module)


def accelerate(model: M) -> M:
    """Swap, in place, every nn.Linear for FastLinear, every LinearGELU (and nn.Linear + nn.GELU pair inside an
    nn.Sequential) for FastLinearGELU, every plain zero-padded nn.Conv1d for FastConv1d, and every module whose
    class has a registered faster subclass (`faster_version_of`) for that subclass. The same parameter tensors stay
    in place (same state_dict keys, same values), training and autograd take the default ops, and
    GESTURELSM_ONEDNN=0 gives the default ops' output exactly. Which fast path a swapped module takes is measured
    at its first call of each shape (choice.py). For inference loaders; idempotent. Returns `model`."""
    for m in list(model.modules()):
        if isinstance(m, nn.Sequential):
            _fuse_gelu_pairs(m)
    for m in model.modules():
        if type(m) is nn.Linear:
            m.__class__ = FastLinear
        elif type(m) is LinearGELU:
            m.__class__ = FastLinearGELU
        elif _conv_swappable(m):
            m.__class__ = FastConv1d
        elif type(m) in _FASTER:
            m.__class__ = _FASTER[type(m)]
    return model


_FASTER: dict[type, type] = {}


def faster_version_of(base: type[nn.Module]) -> Callable[[type[nn.Module]], type[nn.Module]]:
    """Class decorator: register the decorated subclass of `base` as what `accelerate` swaps `base` modules for.
    The subclass adds no parameters or buffers, and computes exactly base.forward when `fast_path()` is off."""
    def register(fast: type[nn.Module]) -> type[nn.Module]:
        assert issubclass(fast, base)
        _FASTER[base] = fast
        return fast
    return register
