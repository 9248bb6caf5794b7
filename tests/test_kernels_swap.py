"""kernels.accelerate: the swapped-in modules keep the model's parameters (same tensors, same state_dict keys),
compute the plain model's function (within fp32 summation-order tolerance on the fast path, exactly with
GESTURELSM_ONEDNN=0 or while autograd records), and the loaders hand out accelerated models."""
from __future__ import annotations

import copy

import pytest
import torch
import torch.nn as nn

from gesturelsm import kernels
from gesturelsm.flows.base import guided
from gesturelsm.generator.config import PRESETS
from gesturelsm.generator.layers import FastCrossBlock, FastSelfAttention
from gesturelsm.generator.model import FastDenoiser, GestureGenerator
from gesturelsm.kernels import FastConv1d, FastLinear, FastLinearGELU, LinearGELU, accelerate
from gesturelsm.tokenizer import RVQVAE, preset

from _support import assert_close_rel


def small_net() -> nn.Module:
    torch.manual_seed(1)
    return nn.Sequential(nn.Conv1d(6, 8, 3, padding=2, dilation=2), nn.ReLU(), nn.Conv1d(8, 8, 4, stride=2, padding=1),
                         nn.Flatten(1), nn.Linear(8 * 16, 40), nn.GELU(), nn.Linear(40, 24), LinearGELU(24, 5))


def generator() -> GestureGenerator:
    torch.manual_seed(0)
    model = GestureGenerator(PRESETS["tiny"]).eval()
    for p in model.parameters():                 # zero-initialised layers would hide mistakes behind zeros
        nn.init.normal_(p, std=0.3) if p.dim() > 1 else nn.init.normal_(p, std=0.1)
    return model


def step(model: GestureGenerator, scale: float = 3.0) -> torch.Tensor:
    c = model.config
    g = torch.Generator().manual_seed(2)
    cond = torch.randn(2, c.window_latents, c.cond_dim, generator=g)
    seed = torch.randn(2, c.num_regions, c.seed_latents, c.latent_dim, generator=g)
    x = torch.randn(2, c.num_regions, c.window_latents, c.latent_dim, generator=g)
    t, d = torch.tensor([0.25, 0.5]), torch.tensor([0.25, 0.0])
    f = model.bind(cond, seed)
    return torch.stack([guided(f, x, t, d, scale), guided(f, x, t, d, scale)])   # the second call reuses the context


def test_the_swap_keeps_parameters_and_state_dict_keys():
    plain = small_net()
    fast = accelerate(copy.deepcopy(plain))
    assert list(fast.state_dict()) == list(plain.state_dict())
    assert all(torch.equal(a, b) for a, b in zip(fast.state_dict().values(), plain.state_dict().values()))
    ptrs = [p.data_ptr() for p in fast.parameters()]
    accelerate(fast)                                                     # idempotent, in place
    assert [p.data_ptr() for p in fast.parameters()] == ptrs
    kinds = [type(m) for m in fast]
    assert kinds == [FastConv1d, nn.ReLU, FastConv1d, nn.Flatten, FastLinearGELU, nn.Identity, FastLinear,
                     FastLinearGELU]


def test_a_swapped_network_computes_the_plain_one():
    plain = small_net()
    fast = accelerate(copy.deepcopy(plain))
    x = torch.randn(3, 6, 32)
    with torch.no_grad():
        assert_close_rel(fast(x), plain(x), 1e-5)


def test_with_the_fast_path_off_the_output_is_the_plain_modules_exactly(monkeypatch):
    monkeypatch.setenv("GESTURELSM_ONEDNN", "0")
    plain, x = small_net(), torch.randn(3, 6, 32)
    fast = accelerate(copy.deepcopy(plain))
    with torch.no_grad():
        assert torch.equal(fast(x), plain(x))
    model = generator()
    fast_gen = accelerate(copy.deepcopy(model))
    with torch.no_grad():
        assert torch.equal(step(fast_gen), step(model))


def test_autograd_takes_the_default_ops_and_gradients_flow():
    plain, x = small_net(), torch.randn(3, 6, 32)
    fast = accelerate(copy.deepcopy(plain))
    y = fast(x)
    assert torch.equal(y, plain(x))
    y.sum().backward()
    assert all(p.grad is not None for p in fast.parameters())
    model = generator().train()
    fast_gen = accelerate(copy.deepcopy(model)).train()
    c = model.config
    args = (torch.randn(2, c.num_regions, c.window_latents, c.latent_dim), torch.rand(2), torch.rand(2),
            torch.randn(2, c.window_latents, c.cond_dim), torch.randn(2, c.num_regions, c.seed_latents, c.latent_dim),
            torch.tensor([False, True]))
    torch.manual_seed(5)
    want = model(*args)
    torch.manual_seed(5)                                                 # same drop-path draws
    got = fast_gen(*args)
    assert torch.equal(got, want)
    got.square().mean().backward()
    assert fast_gen.denoiser.cross[0].attn.q.weight.grad is not None


def test_the_accelerated_generator_samples_what_the_plain_one_samples():
    model = generator()
    fast = accelerate(copy.deepcopy(model))
    assert isinstance(fast.denoiser, FastDenoiser) and isinstance(fast.denoiser.cross[0], FastCrossBlock)
    assert isinstance(fast.denoiser.st[0].temporal, FastSelfAttention)
    assert list(fast.state_dict()) == list(model.state_dict())
    with torch.no_grad():
        want = step(model)
        assert_close_rel(step(fast), want, 1e-5)
        assert_close_rel(step(fast, 1.0), step(model, 1.0), 1e-5)    # unguided: no stacked halves to share


def test_loaders_hand_out_accelerated_models(tmp_path):
    model = generator()
    model.save(tmp_path / "g.safetensors")
    loaded = GestureGenerator.load(tmp_path / "g.safetensors")
    assert isinstance(loaded.denoiser, FastDenoiser) and type(loaded.denoiser.in_proj) is FastLinear
    assert type(GestureGenerator.load(tmp_path / "g.safetensors", accelerated=False).denoiser.in_proj) is nn.Linear
    torch.manual_seed(0)
    tok = RVQVAE(preset("tiny", 78), "upper").eval()
    tok.save(tmp_path / "t.safetensors")
    tok_fast = RVQVAE.load(tmp_path / "t.safetensors")
    assert any(type(m) is FastConv1d for m in tok_fast.modules())
    x = torch.randn(2, 32, 78)
    with torch.no_grad():
        z = tok.encode(x)
        assert_close_rel(tok_fast.encode(x), z, 1e-5)
        q = tok.quantize(z).quantized.reshape(z.shape)
        assert_close_rel(tok_fast.decode(q), tok.decode(q), 1e-5)


needs_op = pytest.mark.skipif(not kernels.onednn_linear_available(),
                              reason="this PyTorch build has no working oneDNN linear op")


@needs_op
def test_on_onednn_the_accelerated_generator_samples_what_the_plain_one_samples(monkeypatch):
    """Where oneDNN is not measured faster it is forced here, so its path is checked on every machine."""
    monkeypatch.setenv("GESTURELSM_KERNELS", "all")
    model = generator()
    fast = accelerate(copy.deepcopy(model))
    with torch.no_grad():
        assert_close_rel(step(fast), step(model), 1e-5)
        x = torch.randn(3, 6, 32)
        assert_close_rel(accelerate(small_net())(x), small_net()(x), 1e-5)   # channels-last convolutions too


@needs_op
def test_the_swapped_linear_runs_on_onednn(monkeypatch):
    from torch.profiler import profile
    monkeypatch.setenv("GESTURELSM_KERNELS", "all")
    layer = accelerate(nn.Sequential(nn.Linear(16, 8), nn.GELU()))
    with torch.no_grad(), profile() as p:
        layer(torch.randn(4, 16))
    assert "mkldnn::_linear_pointwise" in {e.key for e in p.key_averages()}
