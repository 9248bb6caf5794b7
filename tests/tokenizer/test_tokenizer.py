import torch
import pytest

from gesturelsm.motion import REGIONS, Normalizer
from gesturelsm.tokenizer import RVQVAE, preset
from gesturelsm.tokenizer.evaluate import reconstruct, rotation_errors_deg
from gesturelsm.tokenizer.quantizer import EMAQuantizer, ResidualVQ, quantize_stacked

from _support import assert_close_rel


def tiny(in_dim: int = 78, **kw) -> RVQVAE:
    torch.manual_seed(0)
    return RVQVAE(preset("tiny", in_dim), "upper")


def test_codes_to_quantized_equals_forward_quantized():
    m = tiny()
    m.train()
    m(torch.randn(8, 32, 78))  # initialise codebooks from data
    m.eval()
    z = m.encode(torch.randn(3, 32, 78))
    q = m.quantize(z)
    assert q.codes.shape == (24, 3, 2)  # (B*t, layers, groups)
    assert_close_rel(m.codes_to_quantized(q.codes.reshape(3, 8, 3, 2)), q.quantized.reshape(z.shape))
    # first k layers only: unused layers are marked -1 and contribute nothing
    q2 = m.quantize(z, num_layers=2)
    assert (q2.codes[:, 2:] == -1).all() and (q2.codes[:, :2] == q.codes[:, :2]).all()
    assert_close_rel(m.rvq.codes_to_quantized(q2.codes), q2.quantized)


def test_decode_encode_equals_forward_in_eval():
    m = tiny()
    m.train()
    m(torch.randn(8, 32, 78))
    m.eval()
    x = torch.randn(2, 32, 78)
    out = m(x)
    assert_close_rel(m.decode_latents(m.encode(x)), out.recon)
    assert out.latents.shape == (2, 8, 16)


@pytest.mark.parametrize("groups", [1, 4])
def test_residual_layers_reduce_error_monotonically(groups):
    rvq = ResidualVQ(4, 64, 8, dead_threshold=0.0, groups=groups)
    x = torch.randn(2000, 8)
    rvq.train()
    for _ in range(30):
        rvq(x, num_layers=4)
    rvq.eval()
    errs = [(rvq(x, num_layers=k).quantized - x).pow(2).mean().item() for k in range(1, 5)]
    assert all(a > b for a, b in zip(errs, errs[1:])), errs


def test_stacked_quantizers_equal_each_on_its_own():
    """Decoding quantises all regions in one stacked pass; it must pick the codes each quantizer picks alone."""
    torch.manual_seed(0)
    rvqs = [ResidualVQ(3, 16, 8, groups=4) for _ in range(3)]
    for r in rvqs:
        r.train()
        for _ in range(5):
            r(torch.randn(300, 8) * (1 + len(rvqs)))
        r.eval()
    xs = [torch.randn(40, 8) * 2 for _ in rvqs]
    got = quantize_stacked(rvqs, xs)
    for r, x, g in zip(rvqs, xs, got):
        ref = r(x)
        assert_close_rel(g, ref.quantized)
        assert torch.equal(r.codes_to_quantized(ref.codes), g)          # the same codes, summed the same way
    with pytest.raises(ValueError, match="different shapes"):
        quantize_stacked([rvqs[0], ResidualVQ(2, 16, 8, groups=4)], xs[:2])


def test_dead_code_reset_revives_unused_codes():
    q = EMAQuantizer(16, 4, groups=2, decay=0.5, dead_threshold=1.0)
    q.train()
    q(torch.randn(256, 2, 4))
    q.codebook[1, :8] = 1e3   # make half the codes of group 1 unreachable
    q.cluster_size[1, :8] = 0.0
    q.num_resets = 0
    x = torch.randn(256, 2, 4)
    q(x)
    assert q.num_resets >= 8
    assert q.codebook[1, :8].abs().max() < 100          # moved back onto the data
    codes, _ = q(x)
    assert len(set(codes[:, 1].tolist()) & set(range(8))) > 0  # and now used


@pytest.mark.parametrize("groups", [1, 4])
def test_grouped_quantizer_equals_independent_codebooks_per_slice(groups):
    """A grouped layer quantises each slice against its own codebook only."""
    torch.manual_seed(0)
    q = EMAQuantizer(8, 12 // groups, groups)
    q.codebook.normal_()
    q.eval()
    x = torch.randn(50, groups, 12 // groups)
    codes, quant = q(x)  # eval: no update
    for g in range(groups):
        d = torch.cdist(x[:, g], q.codebook[g])
        assert torch.equal(codes[:, g], d.argmin(1))
        assert torch.equal(quant[:, g], q.codebook[g][codes[:, g]])


def test_quantizer_dropout_path_trains_and_is_used():
    m = tiny()
    m.rvq.dropout = 1.0  # always drop to a random k
    m.train()
    seen = set()
    opt = torch.optim.Adam(m.parameters(), 1e-3)
    x = torch.randn(8, 32, 78)
    first = None
    for _ in range(40):
        out = m(x)
        seen.add(out.quant.num_layers)
        opt.zero_grad()
        out.loss.backward()
        opt.step()
        first = first if first is not None else out.recon_loss.item()
    assert len(seen) > 1 and min(seen) >= 1 and max(seen) <= 3
    assert out.recon_loss.item() < first
    assert all(p.grad is not None for p in m.encoder.parameters())  # straight-through reaches the encoder


def test_save_load_round_trip_fp32_and_shipped_fp16(tmp_path):
    m = tiny()
    m.normalizer = Normalizer(torch.randn(78), torch.rand(78) + 0.5)
    m.train()
    m(torch.randn(8, 32, 78))
    m.eval()
    x = torch.randn(2, 32, 78)
    ref = m(x).recon
    full = RVQVAE.load(m.save(tmp_path / "a.safetensors"))
    assert_close_rel(full(x).recon, ref)
    assert torch.equal(full.normalizer.std, m.normalizer.std)
    small = RVQVAE.load(m.save(tmp_path / "b.safetensors", half=True))
    assert (tmp_path / "b.safetensors").stat().st_size < (tmp_path / "a.safetensors").stat().st_size * 0.6
    assert torch.allclose(small(x).recon, ref, atol=5e-2)
    assert small.region == "upper" and small.config == m.config


def test_tiny_model_overfits_a_short_real_clip(real_motion):
    """A few hundred CPU steps on 64 real frames reach a small rotation error (upper body)."""
    torch.manual_seed(0)
    cols = list(REGIONS["upper"].columns)
    clip = real_motion.to_features()[300:364, cols]
    norm = Normalizer.fit(clip)
    m = RVQVAE(preset("tiny", len(cols)), "upper", norm)
    m.rvq.dropout = 0.0
    x = norm.normalize(clip)[None]
    opt = torch.optim.Adam(m.parameters(), 3e-3)
    m.train()
    for _ in range(300):
        out = m(x)
        opt.zero_grad()
        out.loss.backward()
        opt.step()
    rec, _ = reconstruct(m, clip)
    err = rotation_errors_deg("upper", clip, rec).mean().item()
    assert err < 2.0, err


def test_train_and_eval_cli_on_a_tiny_folder(tmp_path, beat2_maker, capsys):
    """train-tokenizer writes resumable checkpoints and shipped fp16 copies; rerunning resumes, not restarts."""
    from gesturelsm.cli import main

    data = tmp_path / "beat2"
    beat2_maker(data, "2_scott_0_1_1", 200)
    args = ["train-tokenizer", "--data", str(data), "--out", str(tmp_path / "run"), "--preset", "tiny",
            "--regions", "upper", "face", "--steps", "6", "--batch-size", "4", "--window", "32",
            "--eval-every", "3", "--ship", str(tmp_path / "ship")]
    assert main(args) == 0
    assert (tmp_path / "run" / "upper.state.pt").exists()
    shipped = RVQVAE.load(tmp_path / "ship" / "face.safetensors")
    assert shipped.region == "face" and shipped.config.in_dim == 106
    state = torch.load(tmp_path / "run" / "upper.state.pt", weights_only=False)
    assert state["step"] == 6
    assert main(args[:-2] + ["--steps", "8"]) == 0   # resumes from step 6 to 8
    assert "resumed at step 6" in capsys.readouterr().out
    assert main(["train-tokenizer", "--data", str(data), "--window", "30"]) == 2  # clear error, no traceback
    assert "multiple of 4" in capsys.readouterr().err

    # --decoder-only: the shipped tokenizer's decoder tuned; encoder and codebooks as shipped, weight recorded
    tune = ["train-tokenizer", "--data", str(data), "--regions", "upper", "--steps", "3", "--batch-size", "4",
            "--window", "32", "--out", str(tmp_path / "tuned"), "--decoder-only", str(tmp_path / "ship")]
    assert main(tune) == 0
    src = RVQVAE.load(tmp_path / "ship" / "upper.safetensors")
    tuned = RVQVAE.load(tmp_path / "tuned" / "upper.safetensors")
    assert tuned.config.accel_weight == 2.0 and src.config.accel_weight == 0.0
    assert torch.equal(src.encoder.net[0].weight, tuned.encoder.net[0].weight)
    assert torch.equal(src.rvq.layers[0].codebook, tuned.rvq.layers[0].codebook)
    assert not torch.equal(src.decoder.net[-1].weight, tuned.decoder.net[-1].weight)
    assert main(tune[:-1] + [str(tmp_path / "nowhere")]) == 2
    assert "no tokenizer checkpoint for upper" in capsys.readouterr().err
    assert main(tune + ["--accel-weight", "-1"]) == 2
    assert main(args[:-2] + ["--accel-weight", "1"]) == 2        # only with --decoder-only


def test_decoder_linear_path_has_no_block_steps():
    """The linear skip must not produce steps every 4 frames: latents that change linearly in time decode to
    a linear ramp (second differences ~0 away from the ends)."""
    from dataclasses import replace

    torch.manual_seed(0)
    cfg = replace(preset("tiny", 12), linear_skip=True)
    m = RVQVAE(cfg, "upper")
    z = torch.linspace(0, 1, 16)[None, :, None] * torch.randn(1, 1, cfg.code_dim)       # (1, 16, D) linear ramp
    y = m.decoder.skip(z.transpose(1, 2)).transpose(1, 2)[0]                           # (64, C)
    acc = (y[2:] - 2 * y[1:-1] + y[:-2])[4:-4].abs().max()
    vel = (y[1:] - y[:-1]).abs().max()
    assert acc < 1e-4 * max(vel.item(), 1e-6) + 1e-6, (acc, vel)


def _second_difference_error(m: RVQVAE, x: torch.Tensor) -> float:
    with torch.no_grad():
        r = m(x).recon
    return (r.diff(n=2, dim=1) - x.diff(n=2, dim=1)).abs().mean().item()


def test_decoder_tuning_changes_only_the_decoder_and_cuts_the_jitter_error(real_motion):
    """tune_decoder on a tokenizer fitted to a real clip: encoder, codebooks and so every code stay bitwise the
    same (generators trained on the latents stay valid); the decoder changes; the config (saved with the model)
    records the weight; and against the same tuning without the weight, the second-difference error is lower."""
    import copy

    from gesturelsm.data.split import Split
    from gesturelsm.tokenizer.train import TrainConfig, tune_decoder

    torch.manual_seed(0)
    cols = list(REGIONS["upper"].columns)
    feats = real_motion.to_features()[300:364]
    m = RVQVAE(preset("tiny", len(cols)), "upper", Normalizer.fit(feats[:, cols]))
    m.rvq.dropout = 0.0
    x = m.normalizer.normalize(feats[:, cols])[None]                               # (1, 64, 78)
    opt = torch.optim.Adam(m.parameters(), 3e-3)
    m.train()
    for _ in range(300):                                                           # as the overfit test above
        out = m(x)
        opt.zero_grad()
        out.loss.backward()
        opt.step()
    m.eval()
    before = {k: v.clone() for k, v in m.state_dict().items()}
    with torch.no_grad():
        codes = m.quantize(m.encode(x)).codes
    split = Split([feats], [feats], ["a"], ["a"], "test")
    cfg = TrainConfig(preset="tiny", steps=100, batch_size=8, window=32, lr=3e-3, eval_every=10_000, mirror=False,
                      device="cpu")
    plain = tune_decoder(copy.deepcopy(m), split, cfg, accel_weight=0.0, log=lambda *_: None)
    tuned = tune_decoder(m, split, cfg, accel_weight=2.0, log=lambda *_: None)
    after = tuned.state_dict()
    for k, v in before.items():
        if not k.startswith("decoder."):
            assert torch.equal(v, after[k]), f"{k} changed"
    assert any(not torch.equal(v, after[k]) for k, v in before.items() if k.startswith("decoder."))
    with torch.no_grad():
        assert torch.equal(tuned.quantize(tuned.encode(x)).codes, codes)
    assert not tuned.training and not any(p.requires_grad for p in tuned.parameters())
    assert tuned.config.accel_weight == 2.0 and plain.config.accel_weight == 0.0
    err_plain, err_tuned = _second_difference_error(plain, x), _second_difference_error(tuned, x)
    assert err_tuned < 0.85 * err_plain, (err_plain, err_tuned)    # measured 0.059 vs 0.075


def test_acceleration_term_of_the_loss_is_zero_for_a_perfect_reconstruction_and_grows_with_jitter():
    from dataclasses import replace

    m = RVQVAE(replace(preset("tiny", 12), vel_weight=0.0, accel_weight=1.0), "upper")
    x = torch.randn(2, 32, 12).cumsum(1)
    assert m.reconstruction_loss(x, x).item() == 0.0
    jitter = torch.zeros_like(x)
    jitter[:, ::2] = 0.01                                         # alternating +-: second difference 0.02 per frame
    base = replace(m.config, accel_weight=0.0)
    loss_with = m.reconstruction_loss(x + jitter, x).item()
    m.config = base
    loss_without = m.reconstruction_loss(x + jitter, x).item()
    assert abs((loss_with - loss_without) - 0.02) < 1e-6, (loss_with, loss_without)
