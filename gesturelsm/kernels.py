"""Fast CPU kernels for inference, and the module swap that puts them into a model (`accelerate`).

Linear layers: PyTorch's CPU wheels send an fp32 `nn.Linear` to MKL's sgemm, and MKL takes its AVX2 code path on
AMD CPUs. On an AMD CPU with AVX-512 (Zen 4/5 EPYC) that leaves the wide FMA units idle, while oneDNN, which
PyTorch already uses for its convolutions, runs the same fp32 product with AVX-512 at about twice the rate
(benchmarks/kernels_speed.py prints both). No reduced precision is involved: outputs differ from F.linear's by
summation order only, and the GELU fused into the product is the exact (erf) one. On a CPU without AVX-512 both
libraries run AVX2 code and oneDNN was measured no faster, so MKL's product stays there.

Convolutions: oneDNN's channels-last 2D kernels run the 1D convolutions of the speech encoders and tokenizers
faster than PyTorch's default layout (benchmarks/kernels_speed.py), so `conv1d_as_2d` runs a 1D convolution as a
(1 x k) 2D one on channels-last tensors (same function), and `conv1d_as_2d_add_` adds one into an existing tensor
in place (a residual connection without a new buffer).

`linear(x, w, b, gelu=...)` takes oneDNN's path when it can: fp32 CPU tensors with no gradient to record, on an
x86 CPU with AVX-512, a PyTorch build that has the op with oneDNN enabled (torch.backends.mkldnn.enabled), and a
first-use self-check against F.linear passed. Otherwise it is F.linear (+ the GELU).

`accelerate(model)` swaps a model's modules, in place, for drop-in subclasses that take these paths: nn.Linear ->
FastLinear, LinearGELU (and nn.Linear + nn.GELU inside an nn.Sequential) -> FastLinearGELU, nn.Conv1d ->
FastConv1d, and any block whose model registered a faster version (`faster_version_of`). Same parameter tensors,
same state_dict keys. With a gradient being recorded, or with GESTURELSM_ONEDNN=0 in the environment (to measure
the difference, or to rule the fast path out), every swapped module computes exactly what the module it replaced
computes. The model loaders (GestureGenerator.load, RVQVAE.load, the reference loaders) call it.

`WeightsCache` keeps values derived from weights (folded BatchNorms, the null condition's keys, traced graphs)
until a weight changes.
"""
from __future__ import annotations

import os
import platform
from typing import Callable, Hashable, TypeVar

import torch
import torch.nn as nn
import torch.nn.functional as F

_state: dict[str, bool] = {}
T = TypeVar("T")
X86 = platform.machine().lower() in ("x86_64", "amd64", "x86", "i686")


def onednn_linear_available() -> bool:
    """Whether oneDNN's fused linear op exists here, is worth taking (see `_check_linear`) and agrees with F.linear
    (checked once per process)."""
    return _available("linear", _check_linear) and worth_onednn()


def worth_onednn() -> bool:
    """Whether the CPU has AVX-512. oneDNN's edge is AVX-512, which MKL leaves unused on AMD CPUs; on an AVX2-only
    CPU both run AVX2 code and oneDNN was measured no faster (slower at the shipped generator's sizes)."""
    return "AVX512" in torch.backends.cpu.get_cpu_capability()


def fast_path() -> bool:
    """Whether accelerated modules take their fast path now: no gradient is being recorded and GESTURELSM_ONEDNN is
    not 0. Off, every module `accelerate` swapped in computes exactly what the module it replaced computes."""
    return not torch.is_grad_enabled() and os.environ.get("GESTURELSM_ONEDNN", "1") != "0"


def _available(name: str, check) -> bool:
    if name not in _state:
        try:
            _state[name] = bool(check())
        except Exception:  # noqa: BLE001 - any failure of a private op means: use the public one
            _state[name] = False
    return (_state[name] and torch.backends.mkldnn.enabled and os.environ.get("GESTURELSM_ONEDNN", "1") != "0")


def _check_linear() -> bool:
    if not (X86 and torch.backends.mkldnn.is_available() and hasattr(torch.ops.mkldnn, "_linear_pointwise")):
        return False
    g = torch.Generator().manual_seed(0)
    x, w, b = (torch.randn(*s, generator=g) for s in ((5, 3, 24), (40, 24), (40,)))
    with torch.no_grad():
        got = torch.ops.mkldnn._linear_pointwise(x, w, b, "gelu", [], "none")
        want = F.gelu(F.linear(x, w, b))
    return got.shape == want.shape and torch.allclose(got, want, rtol=1e-5, atol=1e-5)


def _check_conv_add() -> bool:
    if not (X86 and torch.backends.mkldnn.is_available() and hasattr(torch.ops.mkldnn, "_convolution_pointwise_")):
        return False
    g = torch.Generator().manual_seed(0)
    x, w, b, r = (torch.randn(*s, generator=g) for s in ((2, 6, 50), (5, 6, 7), (5,), (2, 5, 23)))
    x2, w2 = channels_last_1d(x), w[:, :, None].contiguous(memory_format=torch.channels_last)
    out = channels_last_1d(r)
    with torch.no_grad():
        _conv_add_onednn(out, x2, w2, b, 2, 1)
        want = r + F.conv1d(x, w, b, 2, 1)
    return torch.allclose(out[:, :, 0], want, rtol=1e-5, atol=1e-5)


def linear(x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor | None = None, *,
           gelu: bool = False) -> torch.Tensor:
    """F.linear(x, weight, bias) (..., in) -> (..., out), then the exact GELU when `gelu`; oneDNN when it can."""
    if (x.dtype == weight.dtype == torch.float32 and x.device.type == "cpu" and weight.device.type == "cpu"
            and not (torch.is_grad_enabled() and (x.requires_grad or weight.requires_grad
                                                   or (bias is not None and bias.requires_grad)))
            and onednn_linear_available()):
        # strided operands send oneDNN to its reference kernels (a 256 x 256 column slice of a weight took
        # 250 ms instead of 0.1 ms): hand it contiguous ones
        return torch.ops.mkldnn._linear_pointwise(x.contiguous(), weight.contiguous(), bias,
                                                  "gelu" if gelu else "none", [], "none" if gelu else "")
    y = F.linear(x, weight, bias)
    if gelu and not torch.is_grad_enabled():
        return torch.ops.aten.gelu_(y)           # in place: a fresh buffer's first touch costs page faults
    return F.gelu(y) if gelu else y


class WeightsCache:
    """Values derived from weights, each recomputed once any weight it was made from changed: replaced (another
    tensor: load_state_dict(assign=True), .to()) or changed in place (load_state_dict, an optimiser step; seen
    through the tensor's version counter). It holds the tensors a value was made from, so a new tensor cannot
    take a freed one's address and pass for it. Safe to share between threads (at worst a value is made twice)."""

    def __init__(self) -> None:
        self._entries: dict[Hashable, tuple[tuple, list[torch.Tensor], object]] = {}

    def get(self, tag: Hashable, tensors: list[torch.Tensor], make: Callable[[], T]) -> T:
        key = tuple((t.data_ptr(), t._version) for t in tensors)
        entry = self._entries.get(tag)
        if entry is None or entry[0] != key:
            entry = (key, list(tensors), make())
            self._entries[tag] = entry
        return entry[2]  # type: ignore[return-value]


def channels_last_1d(x: torch.Tensor) -> torch.Tensor:
    """(B, C, T) -> (B, C, 1, T) stored channels-last (T-major, C fastest), the layout of conv1d_as_2d."""
    return x[:, :, None].contiguous(memory_format=torch.channels_last)


def conv1d_as_2d(x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor | None, stride: int,
                 padding: int) -> torch.Tensor:
    """F.conv1d on (B, C, 1, T) channels-last input with a (Cout, Cin, 1, k) channels-last weight."""
    return F.conv2d(x, weight, bias, (1, stride), (0, padding))


def conv1d_as_2d_add_(out: torch.Tensor, x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor | None,
                      stride: int, padding: int) -> torch.Tensor:
    """out += conv1d_as_2d(x, ...), in place. oneDNN writes the sum straight into `out` (channels-last, same
    shape as the convolution's output): no new tensor (whose fresh pages cost page faults) and no second pass."""
    if (not torch.is_grad_enabled() and out.is_contiguous(memory_format=torch.channels_last)
            and out.dtype == x.dtype == torch.float32 and out.device.type == x.device.type == "cpu"
            and _available("conv_add", _check_conv_add)):
        return _conv_add_onednn(out, x, weight, bias, stride, padding)
    return out.add_(conv1d_as_2d(x, weight, bias, stride, padding))


def _conv_add_onednn(out, x, weight, bias, stride, padding):
    return torch.ops.mkldnn._convolution_pointwise_.binary(out, x.contiguous(memory_format=torch.channels_last),
                                                           weight, bias, [0, padding], [1, stride], [1, 1], 1,
                                                           "add", 1.0, None, [], None)


# ---- the module swap ------------------------------------------------------------------------------------------

class LinearGELU(nn.Linear):
    """nn.Linear followed by the exact (erf) GELU, as one module: the same parameters and state_dict keys as an
    nn.Linear, so a model can declare a hidden layer whose activation `accelerate` fuses into the product."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return F.gelu(F.linear(x, self.weight, self.bias))


class FastLinear(nn.Linear):
    """nn.Linear through `linear` (oneDNN when it can, else exactly F.linear); what `accelerate` makes of one."""
    fused_gelu = False

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return linear(x, self.weight, self.bias, gelu=self.fused_gelu)


class FastLinearGELU(FastLinear, LinearGELU):
    """LinearGELU through `linear(..., gelu=True)`: product and GELU in one oneDNN call (else exactly LinearGELU)."""
    fused_gelu = True

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return FastLinear.forward(self, x)


class FastConv1d(nn.Conv1d):
    """nn.Conv1d run as a (1 x k) 2D convolution on channels-last tensors (`conv1d_as_2d`) when no gradient is
    recorded, the fast path is on and the CPU is one where oneDNN's linear is taken (AVX-512: on an AVX2-only CPU
    the tokenizers' encode + decode measured 1.17x slower this way); otherwise exactly nn.Conv1d. Its output is a
    (B, C, T) view of channels-last memory, which the next such convolution takes without a copy. The
    channels-last weight is kept until the weight changes."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if (not fast_path() or x.dim() != 3 or x.dtype != torch.float32 or x.device.type != "cpu"
                or not onednn_linear_available()):
            return super().forward(x)
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


def accelerate(model: nn.Module) -> nn.Module:
    """Swap, in place, every nn.Linear for FastLinear, every LinearGELU (and nn.Linear + nn.GELU pair inside an
    nn.Sequential) for FastLinearGELU, every plain zero-padded nn.Conv1d for FastConv1d, and every module whose class
    has a registered faster subclass (`faster_version_of`) for that subclass. The same parameter tensors stay in place (same state_dict keys,
    same values), training and autograd take the default ops, and GESTURELSM_ONEDNN=0 gives the default ops'
    output exactly. For inference loaders; idempotent. Returns `model`."""
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
