"""The body regions, declared once.

A frame of motion is the 433-d *feature vector* (layout below); every region owns a set of its
columns, and the regions partition all 433 columns. Each region is tokenised by its own RVQ-VAE and
is one token per latent frame in the generator. `eyes` is the one region that is not generated:
BEAT2's eye rotations are (near) constant, so they are set to the identity (docs/AUTHORS-CODE.md).

Feature layout (per frame):
    [0, 330)    55 joints x 6D rotation, joint-major (joint j at 6j..6j+5), SMPL-X joint order
    [330, 333)  root translation velocity [dx, y, dz] (see translation.py)
    [333, 433)  100 FLAME expression coefficients
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from .skeleton import JOINT_NAMES, NUM_JOINTS

if TYPE_CHECKING:
    import torch

ROT_DIM = NUM_JOINTS * 6          # 330
TRANS_OFFSET = ROT_DIM            # 330
NUM_EXPRESSIONS = 100
EXPR_OFFSET = ROT_DIM + 3         # 333
FEATURE_DIM = EXPR_OFFSET + NUM_EXPRESSIONS  # 433


@dataclass(frozen=True)
class Region:
    name: str
    joints: tuple[int, ...]          # SMPL-X joints whose 6D rotations belong here (ascending)
    trans: bool = False              # owns the 3 translation-velocity columns
    expressions: bool = False        # owns the 100 expression columns
    generated: bool = True           # False: filled with a constant (identity rotation) on decode

    @property
    def columns(self) -> tuple[int, ...]:
        """Indices into the 433-d feature vector, in the region's own order: joints, trans, expressions."""
        cols = [6 * j + k for j in self.joints for k in range(6)]
        if self.trans:
            cols += list(range(TRANS_OFFSET, TRANS_OFFSET + 3))
        if self.expressions:
            cols += list(range(EXPR_OFFSET, EXPR_OFFSET + NUM_EXPRESSIONS))
        return tuple(cols)

    @property
    def dim(self) -> int:
        return len(self.columns)

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(JOINT_NAMES[j] for j in self.joints)


# The declared table (docs/AUTHORS-CODE.md, the paper): upper 13 joints, hands 30, lower 9 + translation, face.
REGIONS: dict[str, Region] = {
    "upper": Region("upper", (3, 6, 9, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21)),      # 78
    "hands": Region("hands", tuple(range(25, 55))),                                     # 180
    "lower": Region("lower", (0, 1, 2, 4, 5, 7, 8, 10, 11), trans=True),                # 57
    "face": Region("face", (22,), expressions=True),                                   # 106
    "eyes": Region("eyes", (23, 24), generated=False),                                 # 12
}
GENERATED_REGIONS: tuple[str, ...] = tuple(n for n, r in REGIONS.items() if r.generated)

_IDENTITY_6D = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)          # the identity rotation in 6D


def split_regions(x: torch.Tensor, names: tuple[str, ...] = GENERATED_REGIONS) -> dict[str, torch.Tensor]:
    """(..., 433) features -> {region: (..., D_region)}."""
    return {n: x[..., list(REGIONS[n].columns)] for n in names}


def join_regions(parts: dict[str, torch.Tensor]) -> torch.Tensor:
    """{region: (..., D_region)} -> (..., 433) in raw (un-normalised) feature space.

    Regions that are absent and not generated (eyes) get the identity rotation; a missing generated
    region is an error, so nothing is silently dropped.
    """
    import torch                                      # the regions' table itself loads no torch (command help)

    ref = next(iter(parts.values()))
    out = torch.zeros(*ref.shape[:-1], FEATURE_DIM, dtype=ref.dtype, device=ref.device)
    for name, region in REGIONS.items():
        if name in parts:
            if parts[name].shape[-1] != region.dim:
                raise ValueError(f"region {name!r} has {parts[name].shape[-1]} dims, expected {region.dim}")
            out[..., list(region.columns)] = parts[name]
        elif not region.generated:
            ident = torch.tensor(_IDENTITY_6D, dtype=out.dtype, device=out.device)
            for j in region.joints:
                out[..., 6 * j:6 * j + 6] = ident
        else:
            raise KeyError(f"region {name!r} missing")
    return out


def _check_partition() -> None:
    cols = sorted(c for r in REGIONS.values() for c in r.columns)
    assert cols == list(range(FEATURE_DIM)), "regions must partition the feature vector"


_check_partition()
