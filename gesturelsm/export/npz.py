"""BEAT2-compatible npz: what BEAT2 ships, EMAGE/GestureLSM read, and the SMPL-X Blender add-on imports
("Add Animation": it requires `poses`, `trans`, `betas`, `gender` and `mocap_frame_rate`, loads with
`allow_pickle=False`, and takes the joint count from `poses`' width: 165 = 55 SMPL-X joints).

Keys: poses (T, 165) float32 axis-angle (SMPL-X joint order), trans (T, 3) float32 metres y-up,
expressions (T, 100) float32, betas (300,) float32, model 'smplx2020', gender 'neutral',
mocap_frame_rate 30 (int32). No object arrays (plain numpy strings), so no pickling is needed to read it.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from ..motion.sequence import FPS, MotionSequence


def export_npz(seq: MotionSequence, path: str | Path) -> Path:
    """Write `seq` as a BEAT2-layout npz after checking it; returns the path."""
    path = Path(path)
    if path.suffix.lower() != ".npz":
        raise InputError(f"{path}: use a .npz file name")
    if seq.num_frames == 0:
        raise InputError("the motion has no frames")
    if seq.fps != FPS:
        raise InputError(f"the motion is at {seq.fps} fps; BEAT2 files are {FPS} fps")
    for name in ("poses", "trans", "expressions", "betas"):
        if not np.isfinite(getattr(seq, name)).all():
            raise InputError(f"the motion's {name} contain NaN or infinite values")
    return seq.save(path)
