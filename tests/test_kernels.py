"""kernels.py: oneDNN's fp32 linear and channels-last convolution compute exactly what F.linear / F.conv1d compute
(up to summation order), the fast path is really taken where it exists, and it steps aside for autograd.
The module swap (`accelerate`) is tested in tests/test_kernels_swap.py."""
from __future__ import annotations

import pytest
import torch
import torch.nn as nn
import torch.nn.functional as F
from torch.profiler import profile

from gesturelsm.kernels import (WeightsCache, channels_last_1d, conv1d_as_2d, conv1d_as_2d_add_, conv_add_available,
                                linear, onednn_linear_available, ops)

needs_onednn = pytest.mark.skipif(not onednn_linear_available(),
                                  reason="this PyTorch build has no working oneDNN linear op")
needs_conv_add = pytest.mark.skipif(not conv_add_available(),
                                    reason="this PyTorch build has no oneDNN in-place convolution op")


@pytest.fixture(autouse=True)
def every_path_taken(monkeypatch):
    """oneDNN's paths are checked on every machine, also where they are not measured faster."""
    monkeypatch.setenv("GESTURELSM_KERNELS", "all")


def ops_run(fn) -> set[str]:
    with profile() as p:
        fn()
    return {e.key for e in p.key_averages()}


def lin(layer: nn.Linear, x: torch.Tensor, gelu: bool = False) -> torch.Tensor:
    return linear(x, layer.weight, layer.bias, gelu=gelu)


def close(a: torch.Tensor, b: torch.Tensor) -> bool:
    return a.shape == b.shape and bool(torch.allclose(a, b, rtol=1e-5, atol=1e-5 * float(b.abs().max())))


@pytest.mark.parametrize("shape", [(7, 48), (2, 5, 48), (2, 3, 4, 48)])
@pytest.mark.parametrize("with_bias", [True, False])
@pytest.mark.parametrize("gelu", [False, True])
def test_linear_equals_f_linear(shape, with_bias, gelu):
    g = torch.Generator().manual_seed(3)
    x, w, b = torch.randn(*shape, generator=g), torch.randn(33, 48, generator=g), torch.randn(33, generator=g)
    with torch.no_grad():
        got = linear(x, w, b if with_bias else None, gelu=gelu)
        want = F.linear(x, w, b if with_bias else None)
        want = F.gelu(want) if gelu else want          # the exact (erf) GELU, not the tanh approximation
    assert close(got, want)


def test_strided_operands_give_the_same_result():
    """A column slice of a weight and a transposed input (both strided) are handled, not misread."""
    g = torch.Generator().manual_seed(4)
    wide, x = torch.randn(40, 64, generator=g), torch.randn(3, 32, 6, generator=g).transpose(1, 2)
    with torch.no_grad():
        assert close(linear(x, wide[:, 32:]), F.linear(x, wide[:, 32:]))


@needs_onednn
def test_the_onednn_path_is_taken_and_can_be_switched_off(monkeypatch):
    x, layer = torch.randn(4, 16), nn.Linear(16, 8)
    with torch.no_grad():
        assert "mkldnn::_linear_pointwise" in ops_run(lambda: lin(layer, x))
        monkeypatch.setenv("GESTURELSM_ONEDNN", "0")
        assert "mkldnn::_linear_pointwise" not in ops_run(lambda: lin(layer, x))


def test_autograd_falls_back_to_f_linear():
    layer, x = nn.Linear(6, 4), torch.randn(3, 6, requires_grad=True)
    y = lin(layer, x, gelu=True)
    y.sum().backward()
    assert x.grad is not None and layer.weight.grad is not None
    assert torch.equal(y, F.gelu(F.linear(x, layer.weight, layer.bias)))


def test_a_failing_self_check_means_f_linear(monkeypatch):
    monkeypatch.setattr(ops, "_state", {"linear": False, "conv_add": False})
    x, layer = torch.randn(4, 16), nn.Linear(16, 8)
    with torch.no_grad():
        assert torch.equal(lin(layer, x), F.linear(x, layer.weight, layer.bias))


@pytest.mark.parametrize("stride,pad,k", [(1, 7, 15), (5, 1700, 15), (6, 0, 15), (3, 2, 5)])
def test_conv1d_as_2d_equals_conv1d(stride, pad, k):
    g = torch.Generator().manual_seed(5)
    x, w, b = torch.randn(2, 6, 4000, generator=g), torch.randn(10, 6, k, generator=g), torch.randn(10, generator=g)
    with torch.no_grad():
        got = conv1d_as_2d(channels_last_1d(x), w[:, :, None].contiguous(memory_format=torch.channels_last), b,
                           stride, pad)
    assert got.is_contiguous(memory_format=torch.channels_last)
    assert close(got[:, :, 0], F.conv1d(x, w, b, stride, pad))


def test_weights_cache_remakes_a_value_only_when_a_weight_changed():
    layer, made = nn.Linear(3, 2), []
    cache = WeightsCache()
    get = lambda: cache.get("w", list(layer.parameters()), lambda: made.append(1) or layer.weight.sum().item())  # noqa: E731
    first = get()
    assert get() == first and len(made) == 1                      # unchanged: kept
    with torch.no_grad():
        layer.weight.add_(1.0)                                    # in place
    assert get() == pytest.approx(first + 6) and len(made) == 2
    layer.load_state_dict(nn.Linear(3, 2).state_dict())          # copied in
    get()
    assert len(made) == 3
    for _ in range(3):                                            # replaced by new tensors, again and again
        layer.load_state_dict(nn.Linear(3, 2).state_dict(), assign=True)
        assert get() == pytest.approx(layer.weight.sum().item())
    assert len(made) == 6
    assert cache.get("other tag", [layer.weight], lambda: "x") == "x"


@needs_onednn
def test_linear_steps_aside_when_onednn_is_disabled_or_not_x86(monkeypatch):
    x, layer = torch.randn(4, 16), nn.Linear(16, 8)
    with torch.no_grad(), torch.backends.mkldnn.flags(enabled=False):
        assert "mkldnn::_linear_pointwise" not in ops_run(lambda: lin(layer, x))
    monkeypatch.setattr(ops, "X86", False)
    monkeypatch.setattr(ops, "_state", {})
    assert not onednn_linear_available()
    with torch.no_grad():
        assert "mkldnn::_linear_pointwise" not in ops_run(lambda: lin(layer, x))


def conv_case(seed: int = 6):
    g = torch.Generator().manual_seed(seed)
    x, w, b = torch.randn(2, 6, 300, generator=g), torch.randn(10, 6, 15, generator=g), torch.randn(10, generator=g)
    out = torch.randn(2, 10, 100, generator=g)                    # (300 + 2*7 - 15) // 3 + 1 = 100
    return x, w, b, out


@pytest.mark.parametrize("onednn", ["1", "0"])
def test_conv_add_in_place_equals_out_plus_conv(monkeypatch, onednn):
    monkeypatch.setenv("GESTURELSM_ONEDNN", onednn)
    x, w, b, out = conv_case()
    want = out + F.conv1d(x, w, b, 3, 7)
    target = channels_last_1d(out)
    with torch.no_grad():
        got = conv1d_as_2d_add_(target, channels_last_1d(x),
                                w[:, :, None].contiguous(memory_format=torch.channels_last),
                                b, 3, 7)
    assert got.data_ptr() == target.data_ptr()                    # written into the given tensor
    assert close(target[:, :, 0], want)


@needs_conv_add
def test_the_in_place_convolution_runs_on_onednn():
    x, w, b, out = conv_case()
    target, x2 = channels_last_1d(out), channels_last_1d(x)
    w2 = w[:, :, None].contiguous(memory_format=torch.channels_last)
    with torch.no_grad():
        assert "mkldnn::_convolution_pointwise_" in ops_run(lambda: conv1d_as_2d_add_(target, x2, w2, b, 3, 7))
