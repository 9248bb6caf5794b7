"""Steps where the body walks away from a planted foot: when a planted foot is further than `max_splay` from
under its hip (horizontally) and the spot it would be on (its own motion) has moved at least `min_step` away from
the plant, the foot lifts for `step_frames` and lands again on that spot, one foot at a time (the other one holds
the body), instead of the leg stretching out sideways.

The scan is causal (frame by frame, deciding from the past only), so live mode can run it on each chunk's frames
with its state carried over (`StepPlanner`); `plan_steps` runs it over a whole take.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class StepParams:
    max_splay: float = 0.3          # m: a planted foot this far from under its hip steps ...
    min_step: float = 0.05          # m: ... when its own spot is at least this far from the plant
    step_frames: int = 14           # how long a step is in the air (0.47 s at 30 fps)
    lift: float = 0.04              # m: how high the foot is lifted at the middle of a step


class StepPlanner:
    """Contacts in, contacts with steps out, frame by frame, for F feet."""

    def __init__(self, feet: int = 2, params: StepParams = StepParams()):
        self.params = params
        self.plant: list[np.ndarray | None] = [None] * feet
        self.busy = np.zeros(feet, int)                  # frames of the current step still to go

    def step(self, spot: np.ndarray, hip: np.ndarray, contact: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """spot (F, 2) where each foot would be (its own horizontal position), hip (F, 2) its hip's horizontal
        position, contact (F,) bool -> (contact (F,) with the feet in a step lifted, stepping (F,) bool)."""
        F = len(contact)
        out, stepping = np.asarray(contact, bool).copy(), np.zeros(F, bool)
        for f in range(F):
            if self.busy[f] > 0:
                self.busy[f] -= 1
                out[f], stepping[f] = False, True
                continue
            if not contact[f]:
                self.plant[f] = None
                continue
            if self.plant[f] is None:
                self.plant[f] = np.asarray(spot[f], np.float64).copy()
                continue
            held = all(out[g] and self.busy[g] == 0 for g in range(F) if g != f)   # the others hold the body
            p = self.params
            splay = np.hypot(*(hip[f] - self.plant[f]))
            if splay > p.max_splay and np.hypot(*(spot[f] - self.plant[f])) > p.min_step and held:
                self.busy[f] = max(self.params.step_frames - 1, 0)
                self.plant[f] = None
                out[f], stepping[f] = False, True
        return out, stepping


def plan_steps(spot: np.ndarray, hip: np.ndarray, contacts: np.ndarray,
               params: StepParams = StepParams()) -> tuple[np.ndarray, np.ndarray]:
    """(contacts, stepping), both (T, F) bool, for a whole take: spot and hip (T, F, 2), contacts (T, F)."""
    planner = StepPlanner(contacts.shape[1], params)
    out = np.zeros_like(contacts, bool)
    stepping = np.zeros_like(contacts, bool)
    for t in range(len(contacts)):
        out[t], stepping[t] = planner.step(spot[t], hip[t], contacts[t])
    return out, stepping


__all__ = ["StepParams", "StepPlanner", "plan_steps"]
