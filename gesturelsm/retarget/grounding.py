"""Feet on the ground on a character's own legs: the motion retargeted onto a character whose legs differ from
SMPL-X's (longer shins, wider hips) slides its feet even where the SMPL-X motion's are planted, so its legs are
grounded again on its own skeleton, by the same solver (gesturelsm.grounding: contacts, plants, two-bone leg IK).

    legs = character_legs(setup)                   # CharacterLegs, or a str saying why its legs cannot be grounded
    moved = ground_retargeted(result, setup)       # offline: a whole Retargeted (its `note` says why it was not)
    stream = CharacterStreamGrounder(setup)        # live: push(result) per chunk, causally

The character's `LegRig` (grounding/rig.py) holds its hips and, per leg, the humanoid bones of the thigh, shin, foot
and toes (the foot stands in for the toes when it has none), in the retargeting's aligned frame (its left +x, up +y,
forward +z) divided by the retargeting's scale (character units per SMPL-X metre), so grounding's thresholds mean
the same on a character of any size or unit; joints between two of those bones turn with the upper one, as
retargeting moves them. Its floor: y = 0 of the character's world when its rest pose's lowest foot joint stands on
it (VRM's convention; up to a quarter of its leg above it), else that joint's height less SMPL-X's (that joint's
height above the sole, as a share of the leg). The root's horizontal path is the retargeted one (the SMPL-X
motion's, which had its drift removed when it was grounded); only the legs and the root's height change. The hip,
knee and ankle bones' rotations change and every bone under them turns with them; every other bone's local rotation
is the retargeted one, bit for bit.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..body.model import resolve_body
from ..grounding import Grounded, GroundingSettings, Leg, LegRig, ground_legs
from ..grounding.causal import StreamGrounder
from ..motion.skeleton import JOINT_NAMES, PARENTS
from .errors import CharacterError
from .solve import (Retargeted, Setup, SourceBody, local_rotations, moving_joints, prepare, rest_rooted,
                    root_translation)

SETTINGS = GroundingSettings(drift=None)       # the path is the (grounded) SMPL-X motion's; the legs are regrounded
ANKLE_SHARE = 0.087                            # SMPL-X's ankle joint above its sole, share of the leg (hip to ankle)
TOE_SHARE = 0.057                              # ... and its toe joint
FLOOR_SHARE = 0.25                             # a rest foot joint this far above y = 0 (share of the leg) stands on it
SIDES = ("left", "right")


@dataclass(frozen=True)
class CharacterLegs:
    rig: LegRig
    joints: tuple[int, ...]        # the skeleton joint of each rig joint (0: the hips)
    floor: float                   # the floor's height in the aligned frame, character units
    scale: float                   # character units per rig metre


def character_legs(setup: Setup) -> CharacterLegs | str:
    """The character's legs as a LegRig (module docstring), or why they cannot be grounded."""
    skel, q = setup.skel, setup.q
    bones = skel.bones
    joints, legs = [bones["pelvis"]], []
    for side in SIDES:
        names = [f"{side}_{n}" for n in ("hip", "knee", "ankle")]
        names += [f"{side}_foot"] if f"{side}_foot" in bones else []
        k = len(joints)
        joints += [bones[n] for n in names]
        legs.append(Leg(k, k + 1, k + 2, k + 3 if len(names) == 4 else k + 2))
    parents = [-1] + [i - 1 if i not in (legs[0].hip, legs[1].hip) else 0 for i in range(1, len(joints))]
    rest = q[joints]
    thigh = [float(np.linalg.norm(rest[g.knee] - rest[g.hip])) for g in legs]
    shin = [float(np.linalg.norm(rest[g.ankle] - rest[g.knee])) for g in legs]
    leg = float(np.mean(np.add(thigh, shin)))
    why = _degenerate(rest, legs, thigh, shin, leg)
    if why:
        return why
    feet = [j for g in legs for j in (g.ankle, g.toe)]
    lowest = feet[int(np.argmin(rest[feet, 1]))]
    low = float(rest[lowest, 1])
    toes = lowest not in (legs[0].ankle, legs[1].ankle)
    floor = 0.0 if 0.0 <= low <= FLOOR_SHARE * leg else low - (TOE_SHARE if toes else ANKLE_SHARE) * leg
    local = (rest - np.array([0.0, floor, 0.0])) / setup.scale
    rig = LegRig(tuple(parents), local, (legs[0], legs[1]), float(local[[g.ankle for g in legs], 1].mean()),
                 float(local[[g.toe for g in legs], 1].mean()))
    return CharacterLegs(rig, tuple(joints), floor, setup.scale)


def _degenerate(rest: np.ndarray, legs: list[Leg], thigh: list[float], shin: list[float], leg: float) -> str | None:
    """Why legs cannot be grounded: bones of no length, or a rest pose that does not stand on them."""
    if not np.isfinite(rest).all() or leg <= 0:
        return "its rest pose is not finite"
    if min(thigh + shin) < 0.05 * leg:
        return "a thigh or shin bone has no length"
    if abs(rest[legs[0].ankle, 1] - rest[legs[1].ankle, 1]) > 0.05 * leg:
        return "its rest pose does not stand on both feet (one ankle is higher than the other)"
    for g in legs:
        if not rest[g.hip, 1] > rest[g.knee, 1] > rest[g.ankle, 1]:
            return "its rest pose does not stand on its legs (hip, knee and ankle are not one above the other)"
        if rest[g.hip, 1] - rest[g.ankle, 1] < 0.8 * (np.linalg.norm(rest[g.knee] - rest[g.hip])
                                                      + np.linalg.norm(rest[g.ankle] - rest[g.knee])):
            return "its legs are not straight down in its rest pose"
    return None


def to_rig(legs: CharacterLegs, r: Retargeted) -> tuple[np.ndarray, np.ndarray]:
    """The retargeted motion in the rig's convention: local rotations (T, J, 3, 3), root positions (T, 3)."""
    D = r.aligned_delta[:, list(legs.joints)]
    par = np.array([max(p, 0) for p in legs.rig.parents])
    local = np.swapaxes(D[:, par], -1, -2) @ D
    local[:, 0] = D[:, 0]
    hips = r.positions[:, legs.joints[0]] @ r.align.T                      # aligned frame
    return local, (hips - np.array([0.0, legs.floor, 0.0])) / legs.scale


def from_rig(setup: Setup, legs: CharacterLegs, r: Retargeted, g: Grounded) -> Retargeted:
    """`r` with its legs and root height from the grounded rig motion `g`."""
    skel, rig = setup.skel, legs.rig
    old = r.aligned_delta
    R = np.empty_like(g.local)
    R[:, 0] = old[:, legs.joints[0]]
    for k in range(1, len(legs.joints)):
        R[:, k] = R[:, rig.parents[k]] @ g.local[:, k]
    changed = {legs.joints[j]: j for leg in rig.legs for j in (leg.hip, leg.knee, leg.ankle)}
    delta = old.copy()
    anc = np.full(len(skel), -1)
    for i, p in enumerate(skel.parents):
        anc[i] = i if i in changed else (anc[p] if p >= 0 else -1)
    turn = {i: R[:, k] @ np.swapaxes(old[:, i], -1, -2) for i, k in changed.items()}
    for i in np.flatnonzero(anc >= 0):
        delta[:, i] = R[:, changed[i]] if i in changed else turn[anc[i]] @ old[:, i]
    pos = rest_rooted(setup, delta)
    hips = legs.joints[0]
    target = g.root * legs.scale + np.array([0.0, legs.floor, 0.0])
    pos[:, setup.below] += (target - pos[:, hips])[:, None]
    local = r.local_rotation.copy()                    # bones above and beside the legs: the retargeted rotations
    moved = np.intersect1d(moving_joints(setup), np.flatnonzero(anc >= 0))
    local[:, moved] = local_rotations(setup, delta, moved)
    pos_w = pos @ setup.A
    return replace(r, aligned_delta=delta, positions=pos_w, local_rotation=local,
                   root_translation=root_translation(setup, pos_w), note=None)


def smplx_joints(r: Retargeted) -> np.ndarray:
    """(T, 55, 3) the character's own joints in SMPL-X's order and axes (left +x, up +y, forward +z; the
    character's units), for measures written for SMPL-X joints (metrics/feet.py, metrics/amplitude.py): each SMPL-X
    joint is the humanoid bone mapped to it, or (when the character has none) its nearest mapped ancestor's."""
    P = r.positions @ r.align.T
    out = np.empty((r.num_frames, len(PARENTS), 3))
    for j, name in enumerate(JOINT_NAMES):                       # parents come first in SMPL-X's order
        i = r.skeleton.bones.get(name)
        out[:, j] = P[:, i] if i is not None else out[:, max(PARENTS[j], 0)]
    return out


def leg_problem(skel, body=None) -> str | None:
    """The one line a person reads when this skeleton's legs cannot be grounded (retargeted from `body`, the
    mannequin by default), else None."""
    try:
        legs = character_legs(prepare(skel, SourceBody.of(resolve_body(body))))
    except CharacterError:                      # a skeleton retargeting refuses says so itself when it is used
        return None
    return _note(skel, legs) if isinstance(legs, str) else None


def _note(skel, why: str) -> str:
    return f"{skel.source or 'the character'}: its legs cannot be grounded ({why}); they move as retargeted"


def ground_retargeted(r: Retargeted, setup: Setup, settings: GroundingSettings = SETTINGS) -> Retargeted:
    """A whole retargeted motion with its feet planted on the character's own legs (module docstring); one that
    cannot be (legs not found or degenerate, a motion too short or not standing) comes back as it was, with `note`
    saying why."""
    legs = character_legs(setup)
    if isinstance(legs, str):
        return replace(r, note=_note(setup.skel, legs))
    g = ground_legs(legs.rig, *to_rig(legs, r), settings, r.fps)
    if g.note is not None:
        return replace(r, note=f"feet on the ground was not applied on {setup.skel.source or 'the character'}: "
                               f"{g.note}")
    return from_rig(setup, legs, r, g)


class CharacterStreamGrounder:
    """A character's stream grounded causally, chunk by chunk (grounding/causal.py on its legs): `push(result)`
    with each chunk's Retargeted, in order; a character whose legs cannot be grounded passes through, `note` says
    why."""

    def __init__(self, setup: Setup, settings: GroundingSettings = SETTINGS):
        self.setup = setup
        legs = character_legs(setup)
        self.legs = None if isinstance(legs, str) else legs
        self.note = _note(setup.skel, legs) if isinstance(legs, str) else None
        self.grounder = StreamGrounder(self.legs.rig, settings) if self.legs is not None else None

    def push(self, r: Retargeted) -> Retargeted:
        if self.grounder is None or r.num_frames == 0:
            return replace(r, note=self.note)
        g = self.grounder.push(*to_rig(self.legs, r))
        if g.note is not None:
            return replace(r, note=g.note)
        return from_rig(self.setup, self.legs, r, g)


__all__ = ["CharacterLegs", "CharacterStreamGrounder", "character_legs", "from_rig", "ground_retargeted", "leg_problem",
           "smplx_joints", "to_rig"]
