"""The fast CPU operations and when they run: oneDNN's fp32 product, channels-last convolutions, oneDNN's
convolution summed into a residual in place, and the cache of values derived from weights.

Each operation checks once per process that the op exists here and agrees with the default (a private op that
fails or disagrees means: use the public one), then takes its fast path only where choice.taken says so for the
call's shapes (measured on this machine). Otherwise it computes exactly what the default computes.
"""
from __future__ import annotations

import os
import platform
from typing import Callable, Hashable, Optional, TypeVar

import torch
import torch.nn.functional as F

from .choice import taken

_state: dict[str, bool] = {}
T = TypeVar("T")
X86 = platform.machine().lower() in ("x86_64", "amd64", "x86", "i686")
PROBE_ROWS = 1024         # a product with more rows is measured on its first PROBE_ROWS


def fast_path() -> bool:
    """Whether accelerated modules may take a fast path now: no gradient is being recorded and GESTURELSM_ONEDNN is
    not 0. Off, every module `accelerate` swapped in computes exactly what the module it replaced computes."""
    return not torch.is_grad_enabled() and os.environ.get("GESTURELSM_ONEDNN", "1") != "0"


def onednn_enabled() -> bool:
    """oneDNN is built in and enabled (torch.backends.mkldnn) and GESTURELSM_ONEDNN is not 0."""
    return (torch.backends.mkldnn.is_available() and torch.backends.mkldnn.enabled
            and os.environ.get("GESTURELSM_ONEDNN", "1") != "0")


def onednn_linear_available() -> bool:
    """Whether oneDNN's fused linear op exists here, agrees with F.linear (checked once per process) and may run.
    Whether it is faster is measured per shape (`linear`)."""
    return _available("linear", _check_linear)


def conv_add_available() -> bool:
    """Whether oneDNN's in-place convolution-plus-residual op exists here, agrees (checked once) and may run."""
    return _available("conv_add", _check_conv_add)


def _available(name: str, check) -> bool:
    if name not in _state:
        try:
            _state[name] = bool(check())
        except Exception:  # any failure of a private op means: use the public one
            _state[name] = False
    return _state[name] and onednn_enabled()


def _check_linear() -> bool:
    if not (X86 and torch.backends.mkldnn.is_available() and hasattr(torch.ops.mkldnn, "_linear_pointwise")):
        return False
    g = torch.Generator().manual_seed(0)
    x, w, b = (torch.randn(*s, generator=g) for s in ((5, 3, 24), (40, 24), (40,)))
    with torch.no_grad():
        got = _onednn_linear(x, w, b, True)
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


def bucket(n: int) -> int:
    """n rounded up to a power of two: calls of similar size share one measured choice."""
    return 1 << max(0, int(n) - 1).bit_length()


# ---- products ----------------------------------------------------------------------------------------------------

def linear(x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor | None = None, *,
           gelu: bool = False) -> torch.Tensor:
    """F.linear(x, weight, bias) (..., in) -> (..., out), then the exact GELU when `gelu`; oneDNN's product where
    it is available and measured faster for this size (rows rounded up to a power of two, in, out, gelu, bias)."""
    if (x.dtype == weight.dtype == torch.float32 and x.device.type == "cpu" and weight.device.type == "cpu"
            and not (torch.is_grad_enabled() and (x.requires_grad or weight.requires_grad
                                                   or (bias is not None and bias.requires_grad)))
            and x.dim() > 0 and onednn_linear_available()):
        rows = x.numel() // max(1, x.shape[-1])
        key = (f"{bucket(min(rows, PROBE_ROWS))}x{weight.shape[1]}->{weight.shape[0]}", "gelu" if gelu else "",
               "bias" if bias is not None else "")
        if taken("linear", key, lambda: _linear_pair(x, weight, bias, gelu)):
            return _onednn_linear(x, weight, bias, gelu)
    return _default_linear(x, weight, bias, gelu)


def _default_linear(x, weight, bias, gelu: bool) -> torch.Tensor:
    y = F.linear(x, weight, bias)
    if gelu and not torch.is_grad_enabled():
        return torch.ops.aten.gelu_(y)           # in place: a fresh buffer's first touch costs page faults
    return F.gelu(y) if gelu else y


def _onednn_linear(x, weight, bias, gelu: bool) -> torch.Tensor:
    # strided operands send oneDNN to its reference kernels (a 256 x 256 column slice of a weight took
    # 250 ms instead of 0.1 ms): hand it contiguous ones
    x, weight = x.contiguous(), weight.contiguous()
    attr, algorithm = ("gelu", "none") if gelu else ("none", "")
    if torch.jit.is_tracing():                   # the tracer cannot record the op's optional-scalar list itself
        scripted = _scripted_linear()
        return _default_linear(x, weight, bias, gelu) if scripted is None else scripted(x, weight, bias, attr,
                                                                                         algorithm)
    return torch.ops.mkldnn._linear_pointwise(x, weight, bias, attr, [], algorithm)


def _linear_pair(x, weight, bias, gelu: bool):
    if x.numel() // max(1, x.shape[-1]) > PROBE_ROWS:
        x = x.reshape(-1, x.shape[-1])[:PROBE_ROWS]
    return (lambda: _default_linear(x, weight, bias, gelu)), (lambda: _onednn_linear(x, weight, bias, gelu))


def _onednn_linear_script(x: torch.Tensor, w: torch.Tensor, b: Optional[torch.Tensor], attr: str,
                          algorithm: str) -> torch.Tensor:
    return torch.ops.mkldnn._linear_pointwise(x, w, b, attr, [], algorithm)


_SCRIPTED: list[Callable | None] = []


def _scripted_linear() -> Callable | None:
    """oneDNN's product as a TorchScript function (compiled at first use), which a trace records as one call;
    None where it cannot be compiled (no Python source shipped): a trace then records the default product."""
    if not _SCRIPTED:
        try:
            _SCRIPTED.append(torch.jit.script(_onednn_linear_script))
        except Exception:  # TorchScript needs the source and a matching op schema
            _SCRIPTED.append(None)
    return _SCRIPTED[0]


# ---- convolutions ------------------------------------------------------------------------------------------------

def channels_last_1d(x: torch.Tensor) -> torch.Tensor:
    """(B, C, T) -> (B, C, 1, T) stored channels-last (T-major, C fastest), the layout of conv1d_as_2d."""
    return x[:, :, None].contiguous(memory_format=torch.channels_last)


def conv1d_as_2d(x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor | None, stride: int,
                 padding: int) -> torch.Tensor:
    """F.conv1d on (B, C, 1, T) channels-last input with a (Cout, Cin, 1, k) channels-last weight."""
    return F.conv2d(x, weight, bias, (1, stride), (0, padding))


def conv1d_as_2d_add_(out: torch.Tensor, x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor | None,
                      stride: int, padding: int) -> torch.Tensor:
    """out += conv1d_as_2d(x, ...), in place. Where measured faster, oneDNN writes the sum straight into `out`
    (channels-last, same shape as the convolution's output): no new tensor (whose fresh pages cost page faults)
    and no second pass."""
    if (not torch.is_grad_enabled() and out.is_contiguous(memory_format=torch.channels_last)
            and out.dtype == x.dtype == torch.float32 and out.device.type == x.device.type == "cpu"
            and conv_add_available()):
        key = (f"{x.shape[1]}->{weight.shape[0]}", f"k{weight.shape[-1]}", f"stride {stride}",
               f"length {bucket(x.shape[-1])}")
        if taken("conv_add", key, lambda: _conv_add_pair(out, x, weight, bias, stride, padding)):
            return _conv_add_onednn(out, x, weight, bias, stride, padding)
    return out.add_(conv1d_as_2d(x, weight, bias, stride, padding))


def _conv_add_onednn(out, x, weight, bias, stride, padding):
    return torch.ops.mkldnn._convolution_pointwise_.binary(out, x.contiguous(memory_format=torch.channels_last),
                                                           weight, bias, [0, padding], [1, stride], [1, 1], 1,
                                                           "add", 1.0, None, [], None)


def _conv_add_pair(out, x, weight, bias, stride, padding):
    scratch, x1 = out[:1].clone(memory_format=torch.channels_last), x[:1]    # both sides add into a scratch copy
    return ((lambda: scratch.add_(conv1d_as_2d(x1, weight, bias, stride, padding))),
            (lambda: _conv_add_onednn(scratch, x1, weight, bias, stride, padding)))


# ---- values derived from weights ---------------------------------------------------------------------------------

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
