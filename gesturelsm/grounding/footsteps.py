"""Steps where the body walks away from a planted foot: when a planted foot is further than `max_splay` from
under its hip (horizontally) and the spot it would be on (its own motion) has moved at least `min_step` away from
the plant, the foot lifts (for `step_frames`, longer for a longer step) and lands again on that spot, one foot at a
time (the other one holds the body), instead of the leg stretching out sideways (targets.py lifts a travelling
foot over the floor).

The scan is causal (frame by frame, deciding from the past only), so live mode can run it on each chunk's frames
with its state carried over (`StepPlanner`); `plan_steps` runs it over a whole take.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class StepParams:
    max_splay: float = 0.25         # m: a planted foot this far from under its hip steps ...
    min_step: float = 0.05          # m: ... when its own spot is at least this far from the plant
    step_frames: int = 12           # how long a step is in the air at least (0.4 s at 30 fps) ...
    step_speed: float = 0.5         # m/s: ... and longer for a longer step, at this mean speed
    fps: int = 30


class StepPlanner:
    """Contacts in, contacts with steps out, frame by frame, for F feet."""

    def __init__(self, feet: int = 2, params: StepParams = StepParams()):
        self.params = params
        self.plant: list[list[float] | None] = [None] * feet
        self.busy = [0] * feet                           # frames of the current step still to go

    def step(self, spot: np.ndarray, hip: np.ndarray, contact: np.ndarray) -> np.ndarray:
        """spot (F, 2) where each foot would be (its own horizontal position), hip (F, 2) its hip's horizontal
        position, contact (F,) bool -> (F,) contact with the feet that are stepping lifted."""
        return np.array(self._step(np.asarray(spot, np.float64).tolist(), np.asarray(hip, np.float64).tolist(),
                                   np.asarray(contact, bool).tolist()), bool)

    def _step(self, spot: list, hip: list, contact: list) -> list[bool]:
        p, F = self.params, len(contact)
        out = list(contact)
        for f in range(F):
            if self.busy[f] > 0:
                self.busy[f] -= 1
                out[f] = False
                continue
            if not contact[f]:
                self.plant[f] = None
                continue
            plant = self.plant[f]
            if plant is None:
                self.plant[f] = spot[f]
                continue
            held = all(out[g] and self.busy[g] == 0 for g in range(F) if g != f)   # the others hold the body
            splay = math.hypot(hip[f][0] - plant[0], hip[f][1] - plant[1])
            moved = math.hypot(spot[f][0] - plant[0], spot[f][1] - plant[1])
            if splay > p.max_splay and moved > p.min_step and held:
                self.busy[f] = max(p.step_frames, math.ceil(moved / p.step_speed * p.fps)) - 1
                self.plant[f] = None
                out[f] = False
        return out


def plan_steps(spot: np.ndarray, hip: np.ndarray, contacts: np.ndarray,
               params: StepParams = StepParams()) -> np.ndarray:
    """(T, F) contacts with steps, for a whole take: spot and hip (T, F, 2), contacts (T, F) bool."""
    planner = StepPlanner(contacts.shape[1], params)
    rows = [planner._step(s, h, c) for s, h, c in zip(np.asarray(spot, np.float64).tolist(),
                                                    np.asarray(hip, np.float64).tolist(),
                                                    np.asarray(contacts, bool).tolist())]
    return np.array(rows, bool).reshape(contacts.shape)


__all__ = ["StepParams", "StepPlanner", "plan_steps"]
