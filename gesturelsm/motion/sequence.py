"""`MotionSequence`: one SMPL-X motion clip in BEAT2's layout, and its 433-d feature encoding.

BEAT2 npz keys: `poses` (T, 165) axis-angle of the 55 joints (radians), `trans` (T, 3) metres y-up,
`expressions` (T, 100) FLAME coefficients, `betas` (300,), `model`, `gender`, `mocap_frame_rate` (30); and, when
the motion was made from speech, what it was made with: `transcript` (0-d unicode), `words` (N,) unicode and
`word_times` (N, 2) float32 seconds (start, end). BEAT2's readers (EMAGE, the SMPL-X Blender add-on) read the keys
they know and leave these. Files are read by motion_file.py only (header first, no pickles, limits).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import torch

from ..constants import FPS
from ..errors import MotionFileError
from .motion_file import read_motion_file
from .regions import EXPR_OFFSET, FEATURE_DIM, ROT_DIM, TRANS_OFFSET
from .rotations import axis_angle_to_rot6d, rot6d_to_axis_angle
from .skeleton import MIRROR_PERM, NUM_JOINTS
from .translation import trans_to_velocity, velocity_to_trans

NUM_BETAS = 300


@dataclass
class MotionSequence:
    poses: np.ndarray                      # (T, 165) float32, axis-angle, SMPL-X joint order
    trans: np.ndarray                      # (T, 3) float32, metres, y up
    expressions: np.ndarray                # (T, 100) float32
    betas: np.ndarray = field(default_factory=lambda: np.zeros(NUM_BETAS, np.float32))  # (300,)
    fps: int = FPS
    transcript: str | None = None          # the speech's transcript the motion was made with, when known
    words: tuple = ()                      # ((word, start_s, end_s), ...): its words' timings, when known

    def __post_init__(self) -> None:
        self.poses = np.asarray(self.poses, np.float32).reshape(-1, NUM_JOINTS * 3)
        T = len(self.poses)
        self.trans = np.asarray(self.trans, np.float32).reshape(T, 3)
        expr = np.asarray(self.expressions, np.float32)
        self.expressions = expr.reshape(T, -1) if T else expr.reshape(0, expr.shape[-1] if expr.ndim == 2 else 0)
        betas = np.zeros(NUM_BETAS, np.float32)
        b = np.asarray(self.betas, np.float32).reshape(-1)[:NUM_BETAS]
        betas[: len(b)] = b
        self.betas = betas
        self.words = tuple((str(w), float(a), float(b)) for w, a, b in self.words)

    # ---- basics -----------------------------------------------------------------------------------
    @property
    def num_frames(self) -> int:
        return len(self.poses)

    @property
    def duration(self) -> float:
        return self.num_frames / self.fps

    def __len__(self) -> int:
        return self.num_frames

    def slice(self, start: int, stop: int) -> "MotionSequence":
        return replace(self, poses=self.poses[start:stop], trans=self.trans[start:stop],
                       expressions=self.expressions[start:stop], transcript=None, words=())   # other speech

    # ---- file I/O ---------------------------------------------------------------------------------
    @classmethod
    def load(cls, path: str | Path) -> "MotionSequence":
        """A motion file, checked with bounded memory and resampled to 30 fps (motion_file.py: what is taken);
        MotionFileError, one line, for anything else."""
        d = read_motion_file(path)
        return cls(d.poses, d.trans, d.expressions, d.betas, FPS, d.transcript, d.words)

    def npz_arrays(self) -> dict[str, np.ndarray]:
        """The arrays of a BEAT2-compatible npz, by key (export/npz.py documents the layout)."""
        return dict(poses=self.poses.astype(np.float32), trans=self.trans.astype(np.float32),
                    expressions=self.expressions.astype(np.float32), betas=self.betas.astype(np.float32),
                    model=np.array("smplx2020"), gender=np.array("neutral"),
                    mocap_frame_rate=np.array(self.fps, dtype=np.int32), **self.speech_arrays())

    def speech_arrays(self) -> dict[str, np.ndarray]:
        """`transcript`, `words`, `word_times` when the motion keeps what it was made from (else nothing): plain
        unicode and float32 arrays, read without pickles."""
        out = {}
        if self.transcript:
            out["transcript"] = np.array(self.transcript, dtype=str)
        if self.words:
            out["words"] = np.array([w for w, _, _ in self.words], dtype=str)
            out["word_times"] = np.array([(a, b) for _, a, b in self.words], np.float32).reshape(-1, 2)
        return out

    def save(self, path: str | Path) -> Path:
        """Write BEAT2-compatible npz (what the EMAGE Blender add-on reads); returns the file written (numpy adds
        .npz to a name without it)."""
        if self.num_frames == 0:
            raise MotionFileError("the motion has no frames; nothing is written")
        if not np.isfinite(float(self.fps)) or self.fps <= 0:
            raise MotionFileError(f"the motion's frame rate is {self.fps}; nothing is written")
        for name in ("poses", "trans", "expressions", "betas"):     # the writer's guard: never a NaN in a file
            if not np.isfinite(getattr(self, name)).all():
                raise MotionFileError(f"the motion's {name} hold NaN or infinite values; nothing is written")
        path = Path(path)
        if not path.name.endswith(".npz"):
            path = path.with_name(path.name + ".npz")
        path.parent.mkdir(parents=True, exist_ok=True)
        arrays: dict[str, Any] = self.npz_arrays()
        np.savez(path, **arrays)
        return path

    # ---- features ---------------------------------------------------------------------------------
    def to_features(self) -> torch.Tensor:
        """(T, 433) float32: [55 x 6D | dx, y, dz | 100 expressions] (see regions.py)."""
        T = self.num_frames
        aa = torch.from_numpy(self.poses).reshape(T, NUM_JOINTS, 3)
        rot = axis_angle_to_rot6d(aa).reshape(T, ROT_DIM)
        vel = trans_to_velocity(torch.from_numpy(self.trans))
        return torch.cat([rot, vel, torch.from_numpy(self.expressions)], dim=-1).float()

    @classmethod
    def from_features(cls, x: torch.Tensor, betas: np.ndarray | None = None,
                      start_xz: tuple[float, float] = (0.0, 0.0), fps: int = FPS) -> "MotionSequence":
        """Inverse of `to_features` (x, z start at `start_xz`)."""
        x = x.detach().float().cpu()
        if x.ndim != 2 or x.shape[-1] != FEATURE_DIM:
            raise ValueError(f"features must be (T, {FEATURE_DIM}), got {tuple(x.shape)}")
        T = x.shape[0]
        aa = rot6d_to_axis_angle(x[:, :ROT_DIM].reshape(T, NUM_JOINTS, 6)).reshape(T, -1)
        trans = velocity_to_trans(x[:, TRANS_OFFSET:TRANS_OFFSET + 3], start_xz)
        expr = x[:, EXPR_OFFSET:]
        return cls(aa.numpy(), trans.numpy(), expr.numpy(),
                   betas if betas is not None else np.zeros(NUM_BETAS, np.float32), fps)

    # ---- augmentation -----------------------------------------------------------------------------
    def mirrored(self) -> "MotionSequence":
        """Left/right mirror: swap left/right joints, reflect rotations and translation in the x = 0 plane.

        Reflection S = diag(-1, 1, 1): R -> S R S, which for axis-angle (x, y, z) is (x, -y, -z).
        FLAME expressions have no mirror map and are kept as they are.
        """
        aa = self.poses.reshape(-1, NUM_JOINTS, 3)[:, list(MIRROR_PERM)] * np.array([1, -1, -1], np.float32)
        trans = self.trans * np.array([-1, 1, 1], np.float32)
        return replace(self, poses=aa.reshape(-1, NUM_JOINTS * 3), trans=trans)


# Sign flips of S R S on the two 6D rows (row0: (R00, R01, R02), row1: (R10, R11, R12)), S = diag(-1,1,1).
_MIRROR_6D_SIGN = torch.tensor([1.0, -1.0, -1.0, -1.0, 1.0, 1.0])


def mirror_features(x: torch.Tensor) -> torch.Tensor:
    """Mirror (..., T, 433) features; equals `to_features(seq.mirrored())` for x = `seq.to_features()`."""
    rot = x[..., :ROT_DIM].reshape(*x.shape[:-1], NUM_JOINTS, 6)
    rot = rot[..., list(MIRROR_PERM), :] * _MIRROR_6D_SIGN.to(x)
    vel = x[..., TRANS_OFFSET:TRANS_OFFSET + 3] * torch.tensor([-1.0, 1.0, 1.0]).to(x)
    return torch.cat([rot.reshape(*x.shape[:-1], ROT_DIM), vel, x[..., EXPR_OFFSET:]], dim=-1)
