"""A character's skeleton: its joints in parent-before-child order, their rest local transforms, and which
SMPL-X joint each humanoid bone is.

Rest transforms are the joints' own local translation / rotation / scale (glTF node TRS; for BVH, the
OFFSETs with identity rotations), so a rig's bone-axis convention (each joint's local frame) is whatever
the file says. `world` gives the rest world matrices, including any non-joint ancestors above the root
(`base`: e.g. an armature node that turns a Z-up rig into glTF's Y-up world, or scales centimetres).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..motion.rotations import quaternion_xyzw_to_matrix as quat_xyzw_to_matrix  # noqa: F401 (gltf.py imports it here)
from .errors import CharacterError
from .limits import MAX_SKELETON_DEPTH
from .names import REQUIRED



def trs_matrix(t, R, s) -> np.ndarray:
    """4x4 = translation(t) @ rotation(R) @ scale(s)."""
    M = np.eye(4)
    M[:3, :3] = np.asarray(R, np.float64) * np.asarray(s, np.float64)[None, :]
    M[:3, 3] = t
    return M


@dataclass
class Skeleton:
    """Joints in parent-before-child order. `nodes[i]`: the joint's index in its file (glTF node index,
    or BVH joint order); `bones`: SMPL-X joint name -> joint index, for the humanoid bones found."""
    names: list[str]
    parents: np.ndarray                 # (N,) int, -1 for a root; parents[i] < i
    translation: np.ndarray             # (N, 3) rest local translation
    rotation: np.ndarray                # (N, 3, 3) rest local rotation
    scale: np.ndarray                   # (N, 3) rest local scale
    bones: dict[str, int]
    nodes: list[int] = field(default_factory=list)
    base: np.ndarray = field(default_factory=lambda: np.eye(4))   # world matrix above the roots
    source: str = ""
    kind: str = ""                      # "vrm0" | "vrm1" | "gltf" | "bvh"

    def __post_init__(self) -> None:
        self.parents = np.asarray(self.parents, np.int64)
        if not self.nodes:
            self.nodes = list(range(len(self.names)))
        if any(p >= i for i, p in enumerate(self.parents)):
            raise ValueError("Skeleton joints must come parent first")
        missing = [b for b in REQUIRED if b not in self.bones]
        if missing:
            raise CharacterError(f"{self.source or 'character'}: no recognisable humanoid: the bones for "
                                 f"{', '.join(missing)} (SMPL-X names) are missing")
        self._check_rest()

    def _check_rest(self) -> None:
        """CharacterError for a joint chain deeper than MAX_SKELETON_DEPTH, or a joint whose rest transform is
        not finite or cannot be inverted (a zero scale): nothing could pose it."""
        depth = np.zeros(len(self.parents), np.int64)
        for i, p in enumerate(self.parents):
            depth[i] = 0 if p < 0 else depth[p] + 1
        if len(depth) and depth.max() > MAX_SKELETON_DEPTH:
            raise CharacterError(f"{self.source or 'character'}: a joint has {int(depth.max())} joints above it; "
                                 f"at most {MAX_SKELETON_DEPTH} are read")
        M = self.world()
        finite = np.isfinite(M).all(axis=(1, 2))
        det = np.linalg.det(np.where(finite[:, None, None], M[:, :3, :3], 0.0))
        bad = np.nonzero(np.abs(det) <= 1e-30)[0]
        if bad.size:
            i = int(bad[0])
            raise CharacterError(f"{self.source or 'character'}: joint {self.names[i]!r} has a rest transform "
                                 "that is not finite or has a zero scale; it cannot be posed")

    def __len__(self) -> int:
        return len(self.names)

    def world(self) -> np.ndarray:
        """(N, 4, 4) rest world matrices."""
        M = np.empty((len(self), 4, 4))
        for i, p in enumerate(self.parents):
            local = trs_matrix(self.translation[i], self.rotation[i], self.scale[i])
            M[i] = (self.base if p < 0 else M[p]) @ local
        return M

    def index(self, joint: str) -> int | None:
        return self.bones.get(joint)


def world_rotation(M: np.ndarray) -> np.ndarray:
    """Rotation part of (..., 4, 4) world matrices with positive scale: columns normalised, then the nearest
    rotation (SVD), so slightly skewed files still give a proper rotation."""
    A = M[..., :3, :3]
    U, _, Vt = np.linalg.svd(A)
    R = U @ Vt
    return R * np.where(np.linalg.det(R) < 0, -1.0, 1.0)[..., None, None]


def topological(parents_of: dict[int, int], nodes: list[int], source: str) -> list[int]:
    """Nodes ordered parent-first; a node that is its own ancestor raises CharacterError (a cycle)."""
    order: list[int] = []
    state: dict[int, int] = {}                     # 1 visiting, 2 done
    for start in nodes:
        chain = []
        n = start
        while n is not None and state.get(n) is None:
            state[n] = 1
            chain.append(n)
            n = parents_of.get(n)
        if n is not None and state.get(n) == 1:
            raise CharacterError(f"{source}: the skeleton has a cycle (node {n} is its own ancestor)")
        for c in reversed(chain):
            state[c] = 2
            order.append(c)
    return order
