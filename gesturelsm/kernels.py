"""fp32 linear layers through oneDNN on the CPU: the same IEEE fp32 function as F.linear, about twice as fast here.

Why: PyTorch's CPU wheels send an fp32 `nn.Linear` to MKL's sgemm, and MKL takes its AVX2 code path on AMD CPUs.
On this project's machines (AMD EPYC, Zen 5: full-width AVX-512 FMA units) that runs at ~100-115 GFLOP/s per core,
while oneDNN, which PyTorch already uses for its convolutions, runs the same fp32 product with AVX-512 at
~200-250 GFLOP/s (benchmarks/kernels_speed.py prints both). No reduced precision is involved: outputs differ from
F.linear's by summation order only (largest relative error against a float64 product 6-9e-7, MKL's 3-4e-7),
and the GELU fused into the product is the exact (erf) one.

Convolutions: PyTorch's default layout runs the speech encoder's 1D convolutions at 150-240 GFLOP/s here,
oneDNN's channels-last 2D kernels at 225-255 (1.1-1.5x; relative error against float64 1.4-1.7e-6), so
`conv1d_as_2d` runs a 1D convolution as a (1 x k) 2D one on channels-last tensors (same function), and
`conv1d_as_2d_add_` adds one into an existing tensor in place (a residual connection without a new buffer).

`linear(x, w, b, gelu=...)` takes oneDNN's path when it can: fp32 CPU tensors with no gradient to record, on an
x86 machine (elsewhere oneDNN is not known to be faster), a PyTorch build that has the op with oneDNN enabled
(torch.backends.mkldnn.enabled), and a first-use self-check against F.linear passed. Otherwise, or with
GESTURELSM_ONEDNN=0 in the environment (to measure the difference), it is F.linear (+ F.gelu).

`WeightsCache` keeps values derived from weights (folded BatchNorms, the null condition's keys) until a weight
changes.
"""
from __future__ import annotations

import os
import platform
from typing import Callable, Hashable, TypeVar

import torch
import torch.nn.functional as F

_state: dict[str, bool] = {}
T = TypeVar("T")
X86 = platform.machine().lower() in ("x86_64", "amd64", "x86", "i686")


def onednn_linear_available() -> bool:
    """Whether oneDNN's fused linear op exists here and agrees with F.linear (checked once per process)."""
    return _available("linear", _check_linear)


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
    return F.gelu(y) if gelu else y


def lin(module: torch.nn.Linear, x: torch.Tensor, *, gelu: bool = False) -> torch.Tensor:
    """`linear` with an nn.Linear's weight and bias."""
    return linear(x, module.weight, module.bias, gelu=gelu)


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
