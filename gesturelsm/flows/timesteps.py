"""Training-time samplers for t in [0, 1] (t = 0 noise, t = 1 data)."""
from __future__ import annotations

import torch

T_EPS = 1e-5


def sample_t(n: int, kind: str = "beta", alpha: float = 2.0, beta: float = 1.2, device="cpu",
             generator: torch.Generator | None = None) -> torch.Tensor:
    """(n,) times. `beta`: Beta(alpha, beta), GestureLSM's default Beta(2, 1.2) (mean 0.625, skewed toward
    the data end where fine detail is decided); `uniform`: U(0, 1) (rectified flow); `logit_normal`:
    sigmoid(N(0, 1)) (SD3's choice), for ablations. Clipped to [1e-5, 1 - 1e-5]."""
    if kind == "beta":
        # Beta from two Gammas so a torch.Generator controls it (torch.distributions takes none)
        ga = _gamma(n, alpha, generator, device)
        gb = _gamma(n, beta, generator, device)
        t = ga / (ga + gb)
    elif kind == "uniform":
        t = torch.rand(n, generator=generator, device=device)
    elif kind == "logit_normal":
        t = torch.sigmoid(torch.randn(n, generator=generator, device=device))
    else:
        raise ValueError(f"unknown time sampler {kind!r} (beta | uniform | logit_normal)")
    return t.clamp(T_EPS, 1 - T_EPS)


def _gamma(n: int, shape: float, generator, device) -> torch.Tensor:
    """Gamma(shape, 1) by Marsaglia-Tsang (shape >= 1; boosted for shape < 1)."""
    boost = None
    if shape < 1:
        boost = torch.rand(n, generator=generator, device=device) ** (1 / shape)
        shape += 1
    d = shape - 1 / 3
    c = 1 / (9 * d) ** 0.5
    out = torch.empty(n, device=device)
    todo = torch.ones(n, dtype=torch.bool, device=device)
    while todo.any():
        m = int(todo.sum())
        x = torch.randn(m, generator=generator, device=device)
        v = (1 + c * x) ** 3
        u = torch.rand(m, generator=generator, device=device)
        ok = (v > 0) & (torch.log(u) < 0.5 * x * x + d - d * v + d * torch.log(v.clamp_min(1e-12)))
        idx = todo.nonzero().squeeze(1)
        out[idx[ok]] = (d * v)[ok]
        todo[idx[ok]] = False
    return out * boost if boost is not None else out
