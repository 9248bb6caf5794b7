import torch

from gesturelsm.checkpoint import config_from_dict
from gesturelsm.flows import RectifiedFlow, Shortcut
from gesturelsm.generator.config import PRESETS, GeneratorConfig
from gesturelsm.generator.model import GestureGenerator


def _bound(prediction: str, method: str = "gesturelsm"):
    torch.manual_seed(0)
    cfg = GeneratorConfig(**{**PRESETS["tiny"].__dict__, "prediction": prediction,
                             "uses_step_size": method == "gesturelsm"})
    model = GestureGenerator(cfg, method).eval()
    torch.nn.init.normal_(model.denoiser.out.weight, std=0.3)          # a non-zero output layer
    B, c = 2, cfg
    cond = torch.randn(B, c.window_latents, c.cond_dim)
    seed = torch.randn(B, c.num_regions, c.seed_latents, c.latent_dim)
    kv = model.cross_kv(cond, torch.zeros(B, dtype=torch.bool))
    return model, model.bind(cond, seed), seed, kv, torch.randn(B, c.num_regions, c.window_latents, c.latent_dim)


def test_data_prediction_one_step_is_the_denoisers_clean_estimate():
    for method, sampler in (("gesturelsm", Shortcut()), ("rectified_flow", RectifiedFlow())):
        model, f, seed, kv, noise = _bound("data", method)
        with torch.no_grad():
            y = model.denoiser(noise, torch.zeros(2), torch.ones(2) if method == "gesturelsm" else torch.zeros(2),
                               seed, kv)
            assert torch.allclose(sampler.sample(f, noise, 1), y, atol=1e-5)
            # the velocity it reports is the straight line from x_t to that estimate
            t = torch.full((2,), 0.25)
            v = f(noise, t, torch.zeros(2), torch.zeros(2, dtype=torch.bool))
            y_t = model.denoiser(noise, t, torch.zeros(2), seed, kv)
            assert torch.allclose(v, (y_t - noise) / 0.75, atol=1e-5)


def test_velocity_prediction_and_ddim_pass_the_network_output_through():
    for prediction, method in (("velocity", "gesturelsm"), ("data", "ddim")):
        model, f, seed, kv, noise = _bound(prediction, method)
        with torch.no_grad():
            d = torch.zeros(2)
            out = f(noise, torch.full((2,), 0.5), d, torch.zeros(2, dtype=torch.bool))
            assert torch.allclose(out, model.denoiser(noise, torch.full((2,), 0.5), d, seed, kv), atol=1e-6)


def test_checkpoints_without_a_prediction_field_load_as_velocity_models():
    d = dict(PRESETS["tiny"].__dict__)
    d.pop("prediction")
    assert config_from_dict(GeneratorConfig, d).prediction == "velocity"
