"""Linear blend skinning of a character's own mesh, posed by a retargeted motion (numpy).

Per frame: each joint's world matrix comes from the retargeted local rotations, the rest translations and
scales and the hips' translation (`joint_world`); a skinned vertex is
    v' = sum_k w_k  W[j_k] @ IBM[j_k] @ (v + sum_m m_m d_m)
(JOINTS_0 / WEIGHTS_0, the skin's inverse bind matrices IBM, morph targets d with weights m), its normal the
same blend of the matrices' 3 x 3 parts, renormalised. glTF ignores a skinned mesh node's own transform; an
unskinned mesh follows its nearest joint ancestor rigidly (`MeshPart.rigid_joint`), or stays at rest.

    mesh = character_mesh(character.document, character.skeleton)
    W = joint_world(result, frames)                        # (n, N, 4, 4)
    verts, normals = pose_mesh(mesh, W[0], {0: morph})     # one (V, 3) array per part, the character's world
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from .mesh import CharacterMesh, MeshPart
from .skeleton import Skeleton
from .solve import Retargeted, joint_depths

VERTEX_CHUNK = 65_536                 # vertices blended at once (about 25 MB of matrices)


def local_matrices(skel: Skeleton, rotation: np.ndarray, root: int | None = None,
                   root_translation: np.ndarray | None = None) -> np.ndarray:
    """(n, N, 4, 4) local matrices from local rotations (n, N, 3, 3), the rest translations and scales, and
    the root joint's translation per frame (n, 3) when given."""
    n, N = rotation.shape[:2]
    L = np.zeros((n, N, 4, 4))
    L[..., :3, :3] = rotation * skel.scale[None, :, None, :]
    L[..., :3, 3] = skel.translation[None]
    if root is not None and root_translation is not None:
        L[:, root, :3, 3] = root_translation
    L[..., 3, 3] = 1.0
    return L


def world_from_local(skel: Skeleton, L: np.ndarray) -> np.ndarray:
    """(n, N, 4, 4) world matrices of local matrices L (n, N, 4, 4), one tree level at a time."""
    M = np.empty_like(L)
    depth = joint_depths(skel.parents)
    for d in range(int(depth.max()) + 1):
        idx = np.nonzero(depth == d)[0]
        par = skel.parents[idx]
        above = np.where((par >= 0)[None, :, None, None], M[:, np.maximum(par, 0)], skel.base[None, None])
        M[:, idx] = above @ L[:, idx]
    return M


def joint_world(result: Retargeted, frames: Sequence[int] | np.ndarray) -> np.ndarray:
    """(n, N, 4, 4) world matrices of the character's joints at `frames` of the retargeted motion."""
    f = np.asarray(frames, np.int64).reshape(-1)
    skel = result.skeleton
    L = local_matrices(skel, result.local_rotation[f], result.root, result.root_translation[f])
    return world_from_local(skel, L)


def rest_world(skel: Skeleton) -> np.ndarray:
    """(N, 4, 4) the joints' rest world matrices (the bind pose of a file whose skin was bound at rest)."""
    return skel.world()


def _morphed(part: MeshPart, weights: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
    pos, nrm = part.positions, part.normals
    if weights is None or part.targets is None:
        return pos, nrm
    w = np.asarray(weights, np.float64)[: len(part.targets)]
    on = np.nonzero(np.abs(w) > 1e-6)[0]
    if on.size == 0:
        return pos, nrm
    pos = pos + np.einsum("k,kvx->vx", w[on], part.targets[on])
    if nrm is not None and part.target_normals is not None:
        nrm = nrm + np.einsum("k,kvx->vx", w[on], part.target_normals[on])
    return pos, nrm


def pose_part(part: MeshPart, world: np.ndarray,
              morph: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """One part's (V, 3) vertices and (V, 3) unit normals (None when the file has none) in the character's
    world, for joint world matrices `world` (N, 4, 4) and this part's mesh's morph weights (K,) or None."""
    pos, nrm = _morphed(part, morph)
    if part.joints is None:
        M = world[part.rigid_joint] @ part.rigid_offset if part.rigid_joint >= 0 else part.rigid_offset
        v = pos @ M[:3, :3].T + M[:3, 3]
        n = None if nrm is None else nrm @ M[:3, :3].T
    else:
        S = world[part.skin_joints] @ part.inverse_bind                         # (J, 4, 4) skinning matrices
        v = np.empty((len(pos), 3))
        n = None if nrm is None else np.empty((len(nrm), 3))
        for a in range(0, len(pos), VERTEX_CHUNK):                             # bounded memory per call
            c = slice(a, a + VERTEX_CHUNK)
            B = np.einsum("vk,vkab->vab", part.weights[c], S[part.joints[c]][:, :, :3, :])  # (V, 3, 4) blended
            v[c] = np.einsum("vab,vb->va", B[..., :3], pos[c]) + B[..., 3]
            if n is not None:
                n[c] = np.einsum("vab,vb->va", B[..., :3], nrm[c])
    if n is not None:
        n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    return v, n


def pose_mesh(mesh: CharacterMesh, world: np.ndarray, morph: dict[int, np.ndarray] | None = None
              ) -> tuple[list[np.ndarray], list[np.ndarray | None]]:
    """Every part posed (see `pose_part`; a part that shares another's vertices gets that part's arrays);
    `morph`: {mesh index: (K,) weights} for this frame."""
    morph = morph or {}
    out: list[tuple[np.ndarray, np.ndarray | None]] = []
    for p in mesh.parts:
        out.append(out[p.shares] if p.shares >= 0 else pose_part(p, world, morph.get(p.mesh)))
    return [v for v, _ in out], [n for _, n in out]
