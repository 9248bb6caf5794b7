"""BEAT2-compatible npz: what BEAT2 ships, EMAGE/GestureLSM read, and the SMPL-X Blender add-on imports
("Add Animation": it requires `poses`, `trans`, `betas`, `gender` and `mocap_frame_rate`, loads with
`allow_pickle=False`, and takes the joint count from `poses`' width: 165 = 55 SMPL-X joints).

Keys: poses (T, 165) float32 axis-angle (SMPL-X joint order), trans (T, 3) float32 metres y-up,
expressions (T, 100) float32, betas (300,) float32, model 'smplx2020', gender 'neutral',
mocap_frame_rate 30 (int32). No object arrays (plain numpy strings), so no pickling is needed to read it.
"""
from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..motion.sequence import FPS, MotionSequence
from .guard import check_motion, finite


def export_npz(seq: MotionSequence, path: str | Path) -> Path:
    """Write `seq` as a BEAT2-layout npz after checking it; returns the path."""
    path = Path(path)
    if path.suffix.lower() != ".npz":
        raise InputError(f"{path}: use a .npz file name")
    _check(seq)
    return seq.save(path)


def npz_bytes(seq: MotionSequence) -> bytes:
    """The same npz as `export_npz` writes, as bytes that depend on the motion only: np.savez stamps each member
    with the time of writing, this stamps 1980-01-01, so the same motion made twice (here or on a cluster's
    worker) is the same file, byte for byte. np.load reads it as any npz."""
    _check(seq)
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED, allowZip64=True) as zf:
        for key, arr in seq.npz_arrays().items():
            with zf.open(zipfile.ZipInfo(f"{key}.npy", date_time=(1980, 1, 1, 0, 0, 0)), "w", force_zip64=True) as fh:
                np.lib.format.write_array(fh, np.asanyarray(arr), allow_pickle=False)
    return buf.getvalue()


def _check(seq: MotionSequence) -> None:
    check_motion(seq)
    if seq.fps != FPS:
        raise InputError(f"the motion is at {seq.fps} fps; BEAT2 files are {FPS} fps")
    if seq.words:
        finite(np.array([(a, b) for _, a, b in seq.words]), "the motion's word times")
