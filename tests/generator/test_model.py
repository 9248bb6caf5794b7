import torch

from gesturelsm.checkpoint import config_from_dict
from gesturelsm.flows import RectifiedFlow, Shortcut
from gesturelsm.generator.config import PRESETS, GeneratorConfig
from gesturelsm.generator.model import GestureGenerator

from _support import assert_close_rel


def _bound(prediction: str, method: str = "gesturelsm"):
    torch.manual_seed(0)
    cfg = GeneratorConfig(**{**PRESETS["tiny"].__dict__, "prediction": prediction,
                             "uses_step_size": method == "gesturelsm"})
    model = GestureGenerator(cfg, method).eval()
    torch.nn.init.normal_(model.denoiser.out.weight, std=0.3)          # a non-zero output layer
    B, c = 2, cfg
    cond = torch.randn(B, c.window_latents, c.cond_dim)
    seed = torch.randn(B, c.num_regions, c.seed_latents, c.latent_dim)
    kv = model.context(cond, torch.zeros(B, dtype=torch.bool))
    return model, model.bind(cond, seed), seed, kv, torch.randn(B, c.num_regions, c.window_latents, c.latent_dim)


def test_data_prediction_one_step_is_the_denoisers_clean_estimate():
    for method, sampler in (("gesturelsm", Shortcut()), ("rectified_flow", RectifiedFlow())):
        model, f, seed, kv, noise = _bound("data", method)
        with torch.no_grad():
            y = model.denoiser(noise, torch.zeros(2), torch.ones(2) if method == "gesturelsm" else torch.zeros(2),
                               seed, kv)
            assert_close_rel(sampler.sample(f, noise, 1), y)
            # the velocity it reports is the straight line from x_t to that estimate
            t = torch.full((2,), 0.25)
            v = f(noise, t, torch.zeros(2), torch.zeros(2, dtype=torch.bool))
            y_t = model.denoiser(noise, t, torch.zeros(2), seed, kv)
            assert_close_rel(v, (y_t - noise) / 0.75)


def test_velocity_prediction_and_ddim_pass_the_network_output_through():
    for prediction, method in (("velocity", "gesturelsm"), ("data", "ddim")):
        model, f, seed, kv, noise = _bound(prediction, method)
        with torch.no_grad():
            d = torch.zeros(2)
            out = f(noise, torch.full((2,), 0.5), d, torch.zeros(2, dtype=torch.bool))
            assert_close_rel(out, model.denoiser(noise, torch.full((2,), 0.5), d, seed, kv))


def test_checkpoints_without_a_prediction_field_load_as_velocity_models():
    d = dict(PRESETS["tiny"].__dict__)
    d.pop("prediction")
    d.pop("speech_add")
    c = config_from_dict(GeneratorConfig, d)
    assert c.prediction == "velocity" and c.speech_add is False       # the first releases' checkpoints


def test_frame_aligned_speech_reaches_only_its_own_frame():
    """speech_add: with no attention layers to mix frames, changing the speech at latent frame 5 changes the
    prediction at frame 5 only (every region of it), for the conditional rows and not for the null ones.

    The edit must be a random direction, not a constant: the speech term starts with a LayerNorm, which removes
    a constant shift of a frame's features exactly, so `+= 1.0` left only float rounding (~1e-6, machine
    dependent) to detect. Thresholds are relative to the output's scale."""
    from dataclasses import replace

    torch.manual_seed(0)
    cfg = replace(PRESETS["tiny"], speech_add=True, cross_layers=0, st_layers=0, prediction="data")
    model = GestureGenerator(cfg).eval()
    torch.nn.init.normal_(model.denoiser.out.weight, std=0.3)
    c = cfg
    cond = torch.randn(1, c.window_latents, c.cond_dim)
    seed = torch.randn(1, c.num_regions, c.seed_latents, c.latent_dim)
    x = torch.randn(2, c.num_regions, c.window_latents, c.latent_dim)
    t, d, drop = torch.full((2,), 0.3), torch.zeros(2), torch.tensor([False, True])
    cond2 = cond.clone()
    cond2[:, 5] += torch.randn(c.cond_dim)
    with torch.no_grad():
        a, b = model.bind(cond, seed)(x, t, d, drop), model.bind(cond2, seed)(x, t, d, drop)
    scale = a.abs().amax()
    diff = (a - b).abs().amax(dim=-1) / scale                       # (2, R, t), relative to the output's scale
    assert (diff[0, :, 5] > 0.05).all(), diff[0, :, 5]              # every region of the edited frame moves
    others = torch.cat([diff[0, :, :5], diff[0, :, 6:]], dim=1)
    assert others.max() <= 1e-6                                     # other frames: unchanged to float precision
    assert diff[1].max() <= 1e-6                                    # the null condition ignores the speech


def test_preset_overrides_parse_types_and_refuse_bad_values():
    import pytest

    from gesturelsm.errors import UserError
    from gesturelsm.commands.train import preset_with

    c = preset_with("small", ["speech_add=true", "st_layers=6", "audio_channels=8,8,8,16,16,16", "prediction=data",
                              "regions=upper,hands"])
    assert c.speech_add is True and c.st_layers == 6 and c.audio_channels == (8, 8, 8, 16, 16, 16)
    assert c.regions == ("upper", "hands")
    assert c.prediction == "data" and c.dim == PRESETS["small"].dim
    for bad in (["speech_add=maybe"], ["st_layers=six"], ["nonsense=1"], ["st_layers"], ["audio_channels=8,x"]):
        with pytest.raises(UserError):
            preset_with("small", bad)
