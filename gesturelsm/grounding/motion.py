"""Grounding an SMPL-X `MotionSequence` (the decoder's output, ground truth) on a body model: the adapter between
BEAT2's layout (axis-angle poses, translation) and the rig-level solver (solve.py).

Only the root translation and the hips', knees' and ankles' rotations (joints 1, 2, 4, 5, 7, 8) change; every other
column of `poses`, the expressions and the betas are the input's, bit for bit.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from ..body.model import resolve_body
from ..motion.sequence import MotionSequence
from ..motion.skeleton import NUM_JOINTS
from .rig import LegRig, smplx_rig
from .rotations import exp, log
from .solve import GroundingSettings, ground_legs

CHANGED_JOINTS: tuple[int, ...] = (1, 2, 4, 5, 7, 8)          # hips, knees, ankles


@dataclass
class GroundingResult:
    motion: MotionSequence
    contacts: np.ndarray            # (T, 2) bool, left and right foot planted
    note: str | None                # why the motion was left unchanged, or None

    @property
    def warning(self) -> str | None:
        return None if self.note is None else f"Feet on the ground was not applied: {self.note}."


@lru_cache(maxsize=8)
def _rig(body, betas: bytes) -> LegRig:
    return smplx_rig(body, np.frombuffer(betas, np.float32).copy())


def rig_of(seq: MotionSequence, body=None) -> LegRig:
    """The LegRig of the body (resolve_body: the mannequin by default) in the shape of the motion's betas."""
    return _rig(resolve_body(body), np.asarray(seq.betas, np.float32).tobytes())


KNEE_CHAINS: tuple[tuple[int, int, int], ...] = ((1, 4, 7), (2, 5, 8))     # hip, knee, ankle (SMPL-X joints)


def knee_flexion(joints: np.ndarray) -> float:
    """Median knee flexion (degrees) over frames and both legs of world joint positions (T, 55, 3), SMPL-X order:
    the angle between thigh (hip to knee) and shin (knee to ankle), 0 for a straight leg. The real speaker
    (BEAT2 2_scott_0_1_1 on the mannequin) stands at 9 degrees."""
    j = np.asarray(joints, np.float64)
    out = []
    for hip, knee, ankle in KNEE_CHAINS:
        thigh, shin = j[:, knee] - j[:, hip], j[:, ankle] - j[:, knee]
        cos = (thigh * shin).sum(-1) / np.maximum(np.linalg.norm(thigh, axis=-1) * np.linalg.norm(shin, axis=-1), 1e-12)
        out.append(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
    return float(np.median(np.concatenate(out))) if len(j) else float("nan")


def ground_motion(seq: MotionSequence, body=None, settings: GroundingSettings = GroundingSettings()) -> GroundingResult:
    """`seq` with its feet planted on the floor and its drift removed (solve.py); a motion that cannot be grounded
    (too short, NaN, not standing, never still on a foot) comes back unchanged with a note saying why."""
    rig = rig_of(seq, body)
    T = seq.num_frames
    aa = seq.poses.reshape(T, NUM_JOINTS, 3).astype(np.float64)
    local = np.broadcast_to(np.eye(3), (T, NUM_JOINTS, 3, 3)).copy()
    chain = list(rig.chain)
    finite = bool(np.isfinite(aa).all())                     # NaN anywhere: the solver says so and changes nothing
    local[:, chain] = exp(aa[:, chain]) if finite else np.nan
    root = seq.trans.astype(np.float64) + rig.rest[0]
    res = ground_legs(rig, local, root, settings, seq.fps)
    if res.note is not None:
        return GroundingResult(seq, res.contacts, res.note)
    poses = seq.poses.copy()
    cols = np.array([3 * j + k for j in CHANGED_JOINTS for k in range(3)])
    poses[:, cols] = log(res.local[:, list(CHANGED_JOINTS)]).reshape(T, -1).astype(np.float32)
    trans = (res.root - rig.rest[0]).astype(np.float32)
    return GroundingResult(replace(seq, poses=poses, trans=trans), res.contacts, None)


__all__ = ["CHANGED_JOINTS", "GroundingResult", "GroundingSettings", "ground_motion", "knee_flexion", "rig_of"]
