"""The skeleton grounding works on: a joint tree (parents, rest positions), its two legs and where its soles are,
and forward kinematics of the joints the legs need, in numpy.

Convention (SMPL-X's, `body/fk.py`): each joint's local rotation acts in its parent's frame about the joint's
rest position, and the rest frames are aligned with the world axes (metres, y up, facing +z, the body's left +x),
so identity rotations give the rest pose. A character's skeleton is grounded by expressing its motion the same way
(its rest pose must stand on a flat floor with its feet level).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..motion.skeleton import JOINT_INDEX, PARENTS


@dataclass(frozen=True)
class Leg:
    hip: int
    knee: int
    ankle: int
    toe: int


@dataclass(frozen=True, eq=False)
class LegRig:
    """parents (J,) with -1 at the root; rest (J, 3) rest-pose joint positions; legs (left, right).
    `ankle_height` / `toe_height`: the ankle's and the toe joint's height above the floor when the rest pose stands
    on it (so a planted, level foot has its ankle that high). `knee_axis`: the rest-frame axis a knee bends about
    (the body's left, +x: the shin swings back), the fallback when a leg is straight."""
    parents: tuple[int, ...]
    rest: np.ndarray
    legs: tuple[Leg, Leg]
    ankle_height: float
    toe_height: float
    knee_axis: tuple[float, float, float] = (1.0, 0.0, 0.0)

    @cached_property
    def offsets(self) -> np.ndarray:
        """(J, 3) each joint's rest position relative to its parent (the root's: its rest position)."""
        r = np.asarray(self.rest, np.float64)
        par = np.array([max(p, 0) for p in self.parents])
        return np.where(np.array(self.parents)[:, None] >= 0, r - r[par], r)

    @cached_property
    def chain(self) -> tuple[int, ...]:
        """The joints from the root to both toes, parents before children."""
        need: set[int] = set()
        for leg in self.legs:
            j = leg.toe
            while j >= 0:
                need.add(j)
                j = self.parents[j]
        return tuple(sorted(need))

    def lengths(self, leg: Leg) -> tuple[float, float]:
        """Thigh (hip to knee) and shin (knee to ankle) lengths, m."""
        r = np.asarray(self.rest, np.float64)
        return float(np.linalg.norm(r[leg.knee] - r[leg.hip])), float(np.linalg.norm(r[leg.ankle] - r[leg.knee]))

    def foot_forward(self, leg: Leg) -> np.ndarray:
        """(3,) the rest foot's direction seen from above (ankle to toe, horizontal, unit)."""
        d = np.asarray(self.rest, np.float64)[leg.toe] - np.asarray(self.rest, np.float64)[leg.ankle]
        d[1] = 0.0
        n = np.linalg.norm(d)
        return d / n if n > 1e-6 else np.array([0.0, 0.0, 1.0])

    def toe_offset(self, leg: Leg) -> np.ndarray:
        """(3,) toe joint minus ankle joint in the rest pose."""
        r = np.asarray(self.rest, np.float64)
        return r[leg.toe] - r[leg.ankle]


@dataclass
class Posed:
    """World rotations R (T, J, 3, 3) and positions p (T, J, 3) of the rig's chain joints (others left zero)."""
    R: np.ndarray
    p: np.ndarray


def forward(rig: LegRig, local: np.ndarray, root: np.ndarray) -> Posed:
    """Forward kinematics of the chain joints: local rotations (T, J, 3, 3), root joint world positions (T, 3)."""
    T, J = local.shape[:2]
    R = np.zeros((T, J, 3, 3))
    p = np.zeros((T, J, 3))
    off = rig.offsets
    for j in rig.chain:
        par = rig.parents[j]
        if par < 0:
            R[:, j], p[:, j] = local[:, j], root
        else:
            R[:, j] = R[:, par] @ local[:, j]
            p[:, j] = p[:, par] + R[:, par] @ off[j]
    return Posed(R, p)


SMPLX_LEGS = (Leg(*(JOINT_INDEX[f"left_{n}"] for n in ("hip", "knee", "ankle", "foot"))),
              Leg(*(JOINT_INDEX[f"right_{n}"] for n in ("hip", "knee", "ankle", "foot"))))


def smplx_rig(body, betas=None) -> LegRig:
    """The LegRig of an SMPL-X body (body.model.BodyModel, the mannequin or a real model) for `betas`: its rest joints,
    and the sole at the rest mesh's lowest vertex."""
    rest = body.rest_joints(betas).astype(np.float64)
    sole = float(body.rest_vertices(betas)[:, 1].min())
    left = SMPLX_LEGS[0]
    return LegRig(tuple(PARENTS), rest, SMPLX_LEGS, float(rest[left.ankle, 1] - sole),
                  float(rest[left.toe, 1] - sole))
