"""A stream of SMPL-X motion chunks grounded as they come (live mode): the BEAT2-layout adapter (as motion.py's
`ground_motion`) around the causal `StreamGrounder` (causal.py).

    grounder = MotionStreamGrounder()            # per stream; the body: the mannequin unless given
    for seq in chunks:                           # MotionSequence chunks of one stream, in order
        out = grounder.push(seq).motion          # the same frames, feet planted, drift removed

Only the root translation and the hips', knees' and ankles' rotations change; every other column of `poses`, the
expressions and the betas are the chunk's, bit for bit.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..motion.sequence import MotionSequence
from ..motion.skeleton import NUM_JOINTS
from .causal import StreamGrounder
from .motion import CHANGED_JOINTS, GroundingResult, rig_of
from .rotations import exp, log
from .solve import GroundingSettings

_COLS = np.array([3 * j + k for j in CHANGED_JOINTS for k in range(3)])


class MotionStreamGrounder:
    """`push(seq)` -> GroundingResult of that chunk (its `note` says why a chunk was passed through unchanged)."""

    def __init__(self, body=None, settings: GroundingSettings = GroundingSettings()):
        self.body, self.settings = body, settings
        self.grounder: StreamGrounder | None = None       # built on the first chunk (the rig of its betas)

    def push(self, seq: MotionSequence) -> GroundingResult:
        T = seq.num_frames
        if self.grounder is None:
            self.grounder = StreamGrounder(rig_of(seq, self.body), self.settings, seq.fps)
        rig = self.grounder.rig
        aa = seq.poses.reshape(T, NUM_JOINTS, 3).astype(np.float64)
        local = np.broadcast_to(np.eye(3), (T, NUM_JOINTS, 3, 3)).copy()
        chain = list(rig.chain)
        local[:, chain] = exp(aa[:, chain]) if np.isfinite(aa).all() else np.nan
        res = self.grounder.push(local, seq.trans.astype(np.float64) + rig.rest[0])
        if res.note is not None or T == 0:
            return GroundingResult(seq, res.contacts, res.note)
        poses = seq.poses.copy()
        J = list(CHANGED_JOINTS)
        moved = (res.local[:, J] != local[:, J]).any(axis=(2, 3))                   # (T, 6): a leg joint the IK set
        new = log(res.local[:, J]).astype(poses.dtype)                              # (T, 6, 3)
        old = poses[:, _COLS].reshape(T, len(J), 3)
        poses[:, _COLS] = np.where(moved[..., None], new, old).reshape(T, -1)
        trans = (res.root - rig.rest[0]).astype(seq.trans.dtype)
        return GroundingResult(replace(seq, poses=poses, trans=trans), res.contacts, None)


__all__ = ["MotionStreamGrounder"]
