"""Root translation <-> the velocity encoding the generator sees.

`trans` is (T, 3) metres, y up (BEAT2). Encoding: x and z are re-zeroed to frame 0 and replaced by their
per-frame deltas; y stays absolute: `[dx_t, y_t, dz_t]`, with frame 0 copying frame 1's deltas (so a
window never starts with an artificial stop). Decoding integrates dx, dz from 0 and keeps y, so
`velocity_to_trans(trans_to_velocity(tr))` is `tr` with x, z shifted to start at 0.
"""
from __future__ import annotations

import torch


def trans_to_velocity(trans: torch.Tensor) -> torch.Tensor:
    """(..., T, 3) -> (..., T, 3) [dx, y, dz]."""
    vel = trans.clone()
    d = trans[..., 1:, :] - trans[..., :-1, :]
    vel[..., 1:, 0] = d[..., 0]
    vel[..., 1:, 2] = d[..., 2]
    if trans.shape[-2] > 1:
        vel[..., 0, 0] = vel[..., 1, 0]
        vel[..., 0, 2] = vel[..., 1, 2]
    else:
        vel[..., 0, 0] = 0
        vel[..., 0, 2] = 0
    return vel


def velocity_to_trans(vel: torch.Tensor, start_xz: tuple[float, float] = (0.0, 0.0)) -> torch.Tensor:
    """(..., T, 3) [dx, y, dz] -> (..., T, 3) positions; frame 0 sits at `start_xz`."""
    trans = vel.clone()
    for axis, start in ((0, start_xz[0]), (2, start_xz[1])):
        steps = vel[..., :, axis].clone()
        steps[..., 0] = 0  # frame 0's entry is a copy, not a step
        trans[..., :, axis] = start + torch.cumsum(steps, dim=-1)
    return trans
