import torch

from gesturelsm.generator.layers import apply_rotary, rotary_freqs

from _support import assert_close_rel


def test_rotary_rotates_interleaved_pairs_by_position():
    torch.manual_seed(0)
    x = torch.randn(2, 3, 7, 8)                                    # (N, heads, positions, head_dim)
    got = apply_rotary(x, rotary_freqs(7, 8, x.device))
    pos = torch.arange(7, dtype=torch.float32)[:, None]
    ang = pos * (1.0 / 1e4 ** (torch.arange(0, 8, 2, dtype=torch.float32) / 8))[None]   # (7, 4)
    x1, x2 = x[..., 0::2], x[..., 1::2]
    want = torch.stack([x1 * ang.cos() - x2 * ang.sin(), x1 * ang.sin() + x2 * ang.cos()], -1).flatten(-2)
    assert_close_rel(got, want)
    assert torch.allclose(got[..., 0, :], x[..., 0, :])             # position 0 is not rotated
    # relative positions: <R_m q, R_n k> depends only on m - n
    q, k = torch.randn(8), torch.randn(8)
    rq = apply_rotary(q.expand(7, 8), rotary_freqs(7, 8, x.device))
    rk = apply_rotary(k.expand(7, 8), rotary_freqs(7, 8, x.device))
    assert torch.allclose(rq[3] @ rk[1], rq[5] @ rk[3], atol=1e-5)


def test_rotary_tables_first_made_in_inference_mode_still_train():
    """The cached tables are shared by inference and training in one process (the app generates, `train` fine-tunes;
    tests do both): one first made under torch.inference_mode must still take part in a backward pass."""
    from gesturelsm.generator.layers import rotary_freqs_qk

    rotary_freqs.cache_clear()
    rotary_freqs_qk.cache_clear()
    with torch.inference_mode():
        f, fqk = rotary_freqs(5, 4, torch.device("cpu")), rotary_freqs_qk(5, 2, 4, torch.device("cpu"))
    assert not f.is_inference() and not fqk.is_inference()
    x = torch.randn(5, 4, requires_grad=True)
    apply_rotary(x, rotary_freqs(5, 4, x.device)).square().sum().backward()
    assert x.grad is not None and torch.isfinite(x.grad).all()
