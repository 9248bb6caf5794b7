"""fp32 linear layers through oneDNN on the CPU: the same IEEE fp32 function as F.linear, about twice as fast here.

Why: PyTorch's CPU wheels send an fp32 `nn.Linear` to MKL's sgemm, and MKL takes its AVX2 code path on AMD CPUs.
On this project's machines (AMD EPYC, Zen 5: full-width AVX-512 FMA units) that runs at ~110 GFLOP/s per core,
while oneDNN, which PyTorch already uses for its convolutions, runs the same fp32 product with AVX-512 at
~245 GFLOP/s (benchmarks/kernels_speed.py prints both). No reduced precision is involved: outputs differ from
F.linear's by summation order only (~1e-7 relative), and the GELU fused into the product is the exact (erf) one.

Convolutions: oneDNN's 1D kernels run at ~135 GFLOP/s here, its channels-last 2D ones at ~265, so
`conv1d_as_2d` runs a 1D convolution as a (1 x k) 2D one on channels-last tensors (same function).

`linear(x, w, b, gelu=...)` takes oneDNN's path when it can: an fp32 CPU tensor with no gradient to record, on a
PyTorch build that has the op, and a first-use self-check against F.linear passed. Otherwise, or with
GESTURELSM_ONEDNN=0 in the environment (to measure the difference), it is F.linear (+ F.gelu).
"""
from __future__ import annotations

import os

import torch
import torch.nn.functional as F

_state: dict[str, bool] = {}


def onednn_linear_available() -> bool:
    """Whether oneDNN's fused linear op exists here and agrees with F.linear (checked once per process)."""
    if "ok" not in _state:
        _state["ok"] = _self_check()
    return _state["ok"] and os.environ.get("GESTURELSM_ONEDNN", "1") != "0"


def _self_check() -> bool:
    try:
        if not (torch.backends.mkldnn.is_available() and hasattr(torch.ops.mkldnn, "_linear_pointwise")):
            return False
        g = torch.Generator().manual_seed(0)
        x, w, b = (torch.randn(*s, generator=g) for s in ((5, 3, 24), (40, 24), (40,)))
        with torch.no_grad():
            got = torch.ops.mkldnn._linear_pointwise(x, w, b, "gelu", [], "none")
            want = F.gelu(F.linear(x, w, b))
        return got.shape == want.shape and bool(torch.allclose(got, want, rtol=1e-5, atol=1e-5))
    except Exception:  # noqa: BLE001 - any failure of a private op means: use F.linear
        return False


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


def weights_key(tensors: list[torch.Tensor]) -> tuple:
    """Identifies the current values of `tensors` (storage and in-place version): a cache derived from weights
    is stale when this changes (load_state_dict, an optimiser step, .to(), a replaced parameter)."""
    return tuple((t.data_ptr(), t._version) for t in tensors)


def channels_last_1d(x: torch.Tensor) -> torch.Tensor:
    """(B, C, T) -> (B, C, 1, T) stored channels-last (T-major, C fastest), the layout of conv1d_as_2d."""
    return x[:, :, None].contiguous(memory_format=torch.channels_last)


def conv1d_as_2d(x: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor | None, stride: int,
                 padding: int) -> torch.Tensor:
    """F.conv1d on (B, C, 1, T) channels-last input with a (Cout, Cin, 1, k) channels-last weight."""
    return F.conv2d(x, weight, bias, (1, stride), (0, padding))
