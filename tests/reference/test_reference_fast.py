"""The reference models' fast inference paths compute the plain formulas: the cross-attention with its projections
folded into the per-clip speech keys (CrossBlock.context), the speech encoder with BatchNorm folded into
channels-last convolutions, and the kept null-condition keys of guidance; caches follow changed weights."""
from __future__ import annotations

import pytest
import torch
import torch.nn.functional as F

from gesturelsm.reference.config import GeneratorConfig
from gesturelsm.reference.denoiser import CrossBlock, ReferenceDenoiser
from gesturelsm.reference.samplers import guided_kv
from gesturelsm.reference.speech import ReferenceSpeechEncoder

SMALL = GeneratorConfig(input_dim=8, latent_dim=32, ff_size=64, num_layers=2, num_cross=2, num_heads=4,
                        audio_dim=16, vocab_size=50, word_dim=8)


def plain_cross(blk: CrossBlock, x: torch.Tensor, ctx: torch.Tensor) -> torch.Tensor:
    """The reference's cross-attention block written out: q, k, v, softmax(q k^T / sqrt(hd)) v, proj, MLP."""
    B, N, D = x.shape
    H = blk.heads
    split = lambda t: t.reshape(B, -1, H, D // H).transpose(1, 2)  # noqa: E731
    q = split(blk.norm1(x) @ blk.q.weight.T)
    k, v = (split(t) for t in (ctx @ blk.kv.weight.T).chunk(2, -1))
    a = torch.softmax(q @ k.transpose(-1, -2) / (D // H) ** 0.5, -1) @ v
    x = x + blk.proj(a.transpose(1, 2).reshape(B, N, D))
    return x + blk.fc2(F.gelu(F.linear(blk.norm2(x), blk.fc1.weight, blk.fc1.bias)))   # fc1: product, then GELU


@pytest.mark.parametrize("fold", [True, False])
def test_cross_attention_equals_the_plain_formula(fold):
    torch.manual_seed(0)
    blk = CrossBlock(48, 4, 96)
    x, ctx = torch.randn(3, 10, 48), torch.randn(3, 7, 48)
    with torch.no_grad():
        for p in blk.parameters():                       # non-trivial norms and biases
            p.add_(0.1 * torch.randn_like(p))
        got = blk(x, blk.context(ctx, fold))
        want = plain_cross(blk, x, ctx)
    assert torch.allclose(got, want, atol=1e-5)


def randomise_batchnorms(m: torch.nn.Module) -> None:
    for bn in (b for b in m.modules() if isinstance(b, torch.nn.BatchNorm1d)):
        bn.running_mean.normal_(0, 0.3)
        bn.running_var.uniform_(0.5, 2.0)
        bn.weight.data.uniform_(0.5, 1.5)
        bn.bias.data.normal_(0, 0.1)


def test_speech_encoder_fast_path_equals_the_modules_and_follows_new_weights():
    torch.manual_seed(1)
    enc = ReferenceSpeechEncoder(SMALL).eval()
    randomise_batchnorms(enc)
    audio, words = torch.rand(2, 533 * SMALL.frames, 2), torch.randint(0, 50, (2, SMALL.frames))
    kept = audio.clone()
    for _ in range(2):                                   # the second round: after new weights were loaded
        want = enc(audio, words)                         # grad enabled: the modules as written
        with torch.no_grad():
            got = enc(audio, words)                      # folded, channels-last
        assert got.shape == (2, SMALL.seq_len, SMALL.regions * SMALL.latent_dim)
        assert torch.allclose(got, want.detach(), atol=1e-5)
        assert torch.equal(audio, kept)                  # the in-place fast path leaves the caller's audio alone
        other = ReferenceSpeechEncoder(SMALL).eval()
        randomise_batchnorms(other)
        enc.load_state_dict(other.state_dict())


@pytest.mark.parametrize("steps", [1, 2])
def test_guidance_keys_follow_the_null_condition(steps):
    torch.manual_seed(2)
    den = ReferenceDenoiser(SMALL).eval()
    speech = torch.randn(1, SMALL.seq_len, SMALL.regions * SMALL.latent_dim)
    with torch.no_grad():
        guided_kv(den, speech, 2.0, steps)               # keeps the null condition's keys
        for change in (lambda: den.null_cond.normal_(),
                       lambda: den.load_state_dict(ReferenceDenoiser(SMALL).state_dict())):
            change()
            kv = guided_kv(den, speech, 2.0, steps)
            want = den.speech_kv(torch.cat([speech, den.null_cond[None]]), fold=steps > 1)
            assert all(torch.allclose(a, b, atol=1e-6) for pa, pb in zip(kv, want) for a, b in zip(pa, pb))


def test_guidance_keys_pass_gradients_when_they_are_recorded():
    torch.manual_seed(3)
    den = ReferenceDenoiser(SMALL)
    speech = torch.randn(1, SMALL.seq_len, SMALL.regions * SMALL.latent_dim)
    with torch.no_grad():
        guided_kv(den, speech, 2.0)                      # a kept copy exists; training must not use it
    kv = guided_kv(den, speech, 2.0)
    sum(t.sum() for pair in kv for t in pair).backward()
    assert den.null_cond.grad is not None and den.null_cond.grad.abs().sum() > 0
