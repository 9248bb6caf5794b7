"""Our reference implementation equals the authors' code (fe124e0) on recorded inputs/outputs.

The fixture (tests/reference/fixtures, see its README) was recorded by running their code with random
reduced-size weights; the state dicts are saved exactly as their training code saves them.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from gesturelsm.kernels import accelerate
from gesturelsm.reference.convert import (generator_from_state, load_generator, load_rvqs, rvq_from_state,
                                          save_generator, save_rvqs)
from gesturelsm.reference.released_files import load_state, load_vocab
from gesturelsm.reference.speech import features_from_file

FIX = Path(__file__).parent / "fixtures"
TOL = 1e-4
STEPS = {"shortcut": (2, 8), "meanflow": (1, 2), "diffusion": (20,)}


@pytest.fixture(scope="module")
def io() -> dict[str, torch.Tensor]:
    with np.load(FIX / "io.npz") as z:
        return {k: torch.from_numpy(z[k]) for k in z.files}


@pytest.fixture(scope="module")
def window(io):
    u8 = io["gen_audio_u8"]
    audio = u8.float() / 255.0
    audio[..., 1] = u8[..., 1].float()   # channel 1 holds 0/1 onsets
    return audio, io["gen_words"], io["gen_seed"]


@pytest.fixture(scope="module")
def state() -> dict[str, torch.Tensor]:
    return load_state(FIX / "generator.bin", ("model_state_dict", "model_state"))


def _maxdiff(a: torch.Tensor, b: torch.Tensor) -> float:
    assert a.shape == b.shape
    return (a - b).abs().max().item()


@pytest.mark.parametrize("region", ["upper", "hands", "lower"])
def test_rvq_encode_quantise_decode(io, region):
    m = rvq_from_state(load_state(FIX / f"net_300000_{region}.pth", ("net",)))
    with torch.no_grad():
        z = m.encode(io[f"rvq_{region}_in"])
        assert _maxdiff(z, io[f"rvq_{region}_latent"]) <= TOL
        assert torch.equal(m.quantize(z)[1], io[f"rvq_{region}_codes"])
        assert _maxdiff(m.decode(z), io[f"rvq_{region}_recon"]) <= TOL


@pytest.mark.parametrize("method", ["shortcut", "meanflow", "diffusion"])
def test_speech_encoder_and_denoiser_forward(io, window, state, method):
    audio, words, _ = window
    g = generator_from_state(state, method)
    with torch.no_grad():
        speech = g.speech(audio, words)
        assert _maxdiff(speech, io["at_feat"]) <= TOL
        d = io[f"{method}_fwd_d"] if method != "diffusion" else None
        out = g.denoiser(io["fwd_x"][:, :, 0], io[f"{method}_fwd_t"], d, io["fwd_seed"],
                         g.denoiser.speech_kv(speech.expand(2, -1, -1)))
    assert _maxdiff(out, io[f"{method}_fwd_out"][:, :, 0]) <= TOL


@pytest.mark.parametrize("method", ["shortcut", "meanflow", "diffusion"])
def test_full_sampling_run_with_fixed_noise(io, window, state, method):
    audio, words, seed = window
    g = generator_from_state(state, method)
    assert g.cfg.cfg_scale == pytest.approx(io[f"{method}_cfg"].item())  # released guidance settings
    for steps in STEPS[method]:
        lat = g.sample(audio, words, seed, io[f"{method}_{steps}_noise"][:, :, 0], steps=steps)
        ref = io[f"{method}_{steps}_latents"][:, :, 0]
        assert _maxdiff(lat, ref) <= TOL * max(1.0, ref.abs().max().item())


def test_sampling_depends_on_every_step(io, window, state):
    """Guard against a sampler that ignores steps: 2 and 8 shortcut steps give different latents."""
    a, b = io["shortcut_2_latents"], io["shortcut_8_latents"]
    assert (a - b).abs().max() > 100 * TOL


def test_speech_features_from_wav_as_trained(io):
    feat = features_from_file(FIX / "speech.wav")
    ref = io["speech_features"].numpy()
    assert feat.shape == ref.shape
    assert np.abs(feat - ref).max() <= TOL
    ones = np.flatnonzero(feat[:, 1])
    assert ones.size > 0 and ones.max() < feat.shape[0] // 256   # onset frame indices, not sample positions


def test_converted_checkpoints_round_trip(tmp_path, io, window, state):
    """Released files -> our safetensors -> the same outputs."""
    audio, words, seed = window
    g = accelerate(generator_from_state(state, "shortcut"))   # the loader accelerates: compare like with like
    w2i, _ = load_vocab(FIX / "vocab.pkl")
    save_generator(tmp_path / "g.safetensors", g, w2i, "fixture")
    g2, w2i2 = load_generator(tmp_path / "g.safetensors")
    assert w2i2 == w2i and g2.cfg == g.cfg
    noise = io["shortcut_2_noise"][:, :, 0]
    assert torch.equal(g2.sample(audio, words, seed, noise), g.sample(audio, words, seed, noise))
    rvqs = {r: accelerate(rvq_from_state(load_state(FIX / f"net_300000_{r}.pth", ("net",))))
            for r in ("upper", "hands", "lower")}
    stats = {"mean": np.arange(330.0), "std": np.ones(330), "trans_mean": np.zeros(3), "trans_std": np.ones(3)}
    save_rvqs(tmp_path / "r.safetensors", rvqs, stats, "fixture")
    rvqs2, stats2 = load_rvqs(tmp_path / "r.safetensors")
    assert torch.equal(stats2["mean"], torch.arange(330.0))
    with torch.no_grad():
        for r in rvqs:
            x = io[f"rvq_{r}_in"]
            assert torch.equal(rvqs2[r].decode(rvqs2[r].encode(x)), rvqs[r].decode(rvqs[r].encode(x)))
