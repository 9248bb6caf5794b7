import math

import pytest
import torch

from gesturelsm.flows import DDIM, RectifiedFlow, Shortcut, guided, make_method, sample_t
from gesturelsm.flows.ddim import cosine_alpha_bar, model_time

from _support import assert_close_rel


def exact_velocity(x1: torch.Tensor):
    """The true velocity field of the straight path to a single data point x1: (x1 - x_t) / (1 - t)."""
    def f(x, t, d, drop):
        ones = [1] * (x.ndim - 1)
        return (x1.repeat(x.shape[0] // x1.shape[0], *ones) - x) / (1 - t).clamp_min(1e-6).reshape(-1, *ones)
    return f


@pytest.mark.parametrize("method", [Shortcut(), RectifiedFlow()])
@pytest.mark.parametrize("steps", [1, 2, 8])
def test_sampler_given_exact_velocity_lands_on_data(method, steps):
    x1 = torch.randn(3, 4, 8, 5)
    out = method.sample(exact_velocity(x1), torch.randn_like(x1), steps)
    assert_close_rel(out, x1)


def test_ddim_given_exact_x0_lands_on_data_in_one_step():
    x1 = torch.randn(2, 4, 8, 5)
    oracle = lambda x, t, d, drop: x1.repeat(x.shape[0] // 2, 1, 1, 1)  # noqa: E731
    for steps in (1, 5, 20):
        assert_close_rel(DDIM().sample(oracle, torch.randn_like(x1), steps), x1)


def test_shortcut_target_for_a_linear_model_is_the_two_half_step_average():
    torch.manual_seed(0)
    A, b, c = torch.randn(6, 6) * 0.3, torch.randn(6), torch.randn(6)
    f = lambda x, t, d, drop: x @ A.T + t[:, None] * b + d[:, None] * c  # noqa: E731
    x_t, t = torch.randn(5, 6), torch.rand(5) * 0.5
    d = torch.full((5,), 0.25)
    drop = torch.zeros(5, dtype=torch.bool)
    got = Shortcut().consistency_target(f, x_t, t, d, drop)
    v1 = x_t @ A.T + t[:, None] * b + 0.25 * c
    x_mid = x_t + 0.25 * v1
    v2 = x_mid @ A.T + (t + 0.25)[:, None] * b + 0.25 * c
    assert torch.allclose(got, (v1 + v2) / 2, atol=1e-6)
    # the smallest level is queried as the instantaneous (d = 0) velocity
    tiny = torch.full((5,), 1 / 128)
    v1 = x_t @ A.T + t[:, None] * b
    v2 = (x_t + v1 / 128) @ A.T + (t + 1 / 128)[:, None] * b
    assert torch.allclose(Shortcut().consistency_target(f, x_t, t, tiny, drop), (v1 + v2) / 2, atol=1e-6)


def test_shortcut_loss_rows_use_grid_times_and_double_step():
    seen = {}

    def f(x, t, d, drop, rows=None):
        seen.setdefault("calls", []).append((t.clone(), d.clone()))
        if rows is not None:
            assert torch.equal(rows, torch.arange(16))  # teacher calls name the rows they are for
        return torch.zeros_like(x)

    g = torch.Generator().manual_seed(0)
    Shortcut().loss(f, torch.randn(64, 3), generator=g)
    t, d = seen["calls"][-1]                       # the prediction call (after two teacher calls)
    sc = d > 0
    assert sc.sum() == 16                           # 25 % consistency rows
    assert torch.all(t[sc] + d[sc] <= 1 + 1e-6)     # a 2d step never passes the data end
    assert torch.allclose(t[sc] / d[sc], torch.round(t[sc] / d[sc]), atol=1e-4)  # on the grid of 2d
    assert set((1 / d[sc]).round().tolist()) <= {1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0}


def test_cfg_scale_one_is_the_conditional_prediction_and_batches_both_halves():
    calls = []

    def f(x, t, d, drop):
        calls.append(x.shape[0])
        return torch.where(drop.reshape(-1, 1), torch.full_like(x, -1.0), x + 1)

    x = torch.randn(4, 3)
    t = d = torch.zeros(4)
    assert torch.equal(guided(f, x, t, d, 1.0), x + 1) and calls == [4]
    out = guided(f, x, t, d, 2.0)
    assert calls[-1] == 8                                   # one batched call for both halves
    assert torch.allclose(out, -1 + 2 * (x + 1 + 1))        # u + s (c - u)


@pytest.mark.parametrize("alpha,beta", [(2.0, 1.2), (1.0, 1.0), (0.7, 3.0)])
def test_beta_sampler_mean_matches_alpha_over_alpha_plus_beta(alpha, beta):
    t = sample_t(200_000, "beta", alpha, beta, generator=torch.Generator().manual_seed(0))
    assert abs(t.mean().item() - alpha / (alpha + beta)) < 3e-3
    var = alpha * beta / ((alpha + beta) ** 2 * (alpha + beta + 1))
    assert abs(t.var().item() - var) < 3e-3
    assert t.min() >= 1e-5 and t.max() <= 1 - 1e-5


def test_other_time_samplers():
    g = torch.Generator().manual_seed(0)
    assert abs(sample_t(100_000, "uniform", generator=g).mean().item() - 0.5) < 5e-3
    assert abs(sample_t(100_000, "logit_normal", generator=g).median().item() - 0.5) < 1e-2
    with pytest.raises(ValueError):
        sample_t(3, "cauchy")


def test_cosine_schedule_and_time_convention():
    ab = cosine_alpha_bar()
    assert ab.shape == (1000,) and ab[0] > 0.999 and ab[-1] < 1e-6
    assert torch.all(ab[1:] <= ab[:-1])
    assert model_time(torch.tensor(999)).item() == 0.0          # pure noise is t = 0
    assert math.isclose(model_time(torch.tensor(0)).item(), 0.999, abs_tol=1e-6)


@pytest.mark.parametrize("name", ["gesturelsm", "rectified_flow", "ddim"])
def test_every_method_learns_a_toy_distribution(name):
    """Same tiny network, each method's own loss: few-step samples land near the two data modes."""
    torch.manual_seed(0)
    net = torch.nn.Sequential(torch.nn.Linear(4, 64), torch.nn.SiLU(), torch.nn.Linear(64, 64), torch.nn.SiLU(),
                              torch.nn.Linear(64, 2))
    f = lambda x, t, d, drop, rows=None: net(torch.cat([x, t[:, None], d[:, None]], 1))  # noqa: E731
    m = make_method(name)
    opt = torch.optim.Adam(net.parameters(), 3e-3)
    g = torch.Generator().manual_seed(0)
    for _ in range(1500):
        x1 = torch.where(torch.rand(256, 1, generator=g) < 0.5, -1.0, 1.0) * torch.tensor([2.0, 1.0])
        loss = m.loss(f, x1, cond_drop_p=0.0, generator=g).loss
        opt.zero_grad()
        loss.backward()
        opt.step()
    with torch.no_grad():
        steps = 4 if name != "ddim" else 10
        out = m.sample(f, torch.randn(512, 2, generator=g), steps)
    dist = torch.minimum((out - torch.tensor([2.0, 1.0])).norm(dim=1), (out + torch.tensor([2.0, 1.0])).norm(dim=1))
    assert dist.median() < 0.35, dist.median()
    assert 0.25 < (out[:, 0] > 0).float().mean() < 0.75   # both modes, not collapsed


def test_data_parametrisation_lands_on_the_prediction_and_its_loss_is_the_x1_error():
    from gesturelsm.flows.base import flow_loss, velocity_from_data

    torch.manual_seed(0)
    x1_hat = torch.randn(3, 4, 8, 5)
    f = lambda x, t, d, drop: velocity_from_data(x1_hat.repeat(x.shape[0] // 3, 1, 1, 1), x, t)  # noqa: E731
    for method in (Shortcut(), RectifiedFlow()):
        for steps in (1, 3):  # whatever the noise, the last Euler step lands exactly on the prediction
            assert_close_rel(method.sample(f, torch.randn_like(x1_hat), steps, cfg_scale=2.0), x1_hat)
    # loss in data space = squared error of the implied clean sample x_t + (1 - t) v
    x_t, v, v_star, t = torch.randn(4, 6), torch.randn(4, 6), torch.randn(4, 6), torch.rand(4)
    x1_from = lambda vel: x_t + (1 - t)[:, None] * vel  # noqa: E731
    assert torch.allclose(flow_loss(v, v_star, t, "data"), (x1_from(v) - x1_from(v_star)).pow(2).mean(1), atol=1e-6)
    assert torch.allclose(flow_loss(v, v_star, t, "velocity"), (v - v_star).pow(2).mean(1))
    with pytest.raises(ValueError, match="loss space"):
        flow_loss(v, v_star, t, "x0")


@pytest.mark.parametrize("method", [Shortcut(loss_space="data"), RectifiedFlow(loss_space="data")])
def test_data_space_loss_is_zero_for_the_exact_field(method):
    x1 = torch.randn(4, 2, 8, 3)

    def f(x, t, d, drop, rows=None):   # the straight-path velocity to this batch's own data
        target = x1 if rows is None else x1[rows]
        return (target - x) / (1 - t).clamp_min(1e-6).reshape(-1, 1, 1, 1)
    assert method.loss(f, x1, 0.0).loss.item() < 1e-8


@pytest.mark.parametrize("method", [Shortcut(), RectifiedFlow(), DDIM()])
def test_inpainting_feeds_the_model_the_known_part_noised_to_its_time(method):
    """Before every call (CFG-stacked batch included) the known entries are the known data noised with the
    sampler's own noise by the method's forward process; the rest is the sampler's state, untouched."""
    from gesturelsm.flows.base import inpainting

    torch.manual_seed(0)
    known, noise = torch.randn(2, 3, 8, 4), torch.randn(2, 3, 8, 4)
    mask = (torch.arange(8) < 3)[None, None, :, None]
    seen = []

    def f(x, t, d, drop):
        seen.append((x.clone(), t.clone()))
        return torch.ones_like(x)

    method.sample(inpainting(f, method, known, mask, noise), noise, 3, cfg_scale=2.0)
    assert len(seen) == 3
    for i, (x, t) in enumerate(seen):
        assert x.shape[0] == 4                                           # both CFG halves
        expect = method.noised(known.repeat(2, 1, 1, 1), noise.repeat(2, 1, 1, 1), t)
        assert torch.equal(x[:, :, :3], expect[:, :, :3])
        if i:                                                            # the unknown part is the sampler's own
            assert not torch.allclose(x[:, :, 3:], expect[:, :, 3:])
    first = seen[0][0]
    assert torch.equal(first[:2, :, 3:], noise[:, :, 3:])               # the first call sees the initial noise there


def test_noised_is_each_methods_training_path():
    x1, x0 = torch.randn(3, 5), torch.randn(3, 5)
    t = torch.tensor([0.0, 0.3, 1.0])
    for m in (Shortcut(), RectifiedFlow()):
        assert_close_rel(m.noised(x1, x0, t), t[:, None] * x1 + (1 - t[:, None]) * x0)
    k = torch.tensor([999, 500, 0])
    ab = cosine_alpha_bar()[k][:, None]
    assert_close_rel(DDIM().noised(x1, x0, model_time(k)), ab.sqrt() * x1 + (1 - ab).sqrt() * x0)


@pytest.mark.parametrize("method", [Shortcut(), RectifiedFlow(), DDIM()])
def test_soft_inpainting_mixes_the_noised_known_part_in_by_its_weight(method):
    from gesturelsm.flows.base import inpainting

    torch.manual_seed(0)
    known, noise = torch.randn(1, 2, 6, 3), torch.randn(1, 2, 6, 3)
    weight = torch.tensor([1.0, 0.5, 0.0, 0.0, 0.0, 0.0]).reshape(1, 1, 6, 1)
    seen = []

    def f(x, t, d, drop):
        seen.append((x.clone(), t.clone()))
        return torch.ones_like(x)

    method.sample(inpainting(f, method, known, weight, noise), noise, 2, cfg_scale=1.0)
    x, t = seen[-1]
    x_prev, _ = seen[-2]
    noised = method.noised(known, noise, t)
    assert torch.equal(x[:, :, 0], noised[:, :, 0])                          # weight 1: the known part only
    assert not torch.allclose(x[:, :, 1], noised[:, :, 1])                   # weight 0.5: mixed with the state
