"""Load an SMPL-X body (the real SMPLX_NEUTRAL_2020.npz or the built-in mannequin) and pose it.

Path resolution for `load_body_model(path)` (see `model_file.py`): the argument, else the environment variable
`GESTURELSM_SMPLX_MODEL`, else the shipped mannequin (`assets/body/SMPLX_MANNEQUIN.npz`). A directory is
searched for SMPLX_NEUTRAL_2020.npz / SMPLX_NEUTRAL.npz (also in a `smplx/` subfolder, EMAGE's layout).

Both kinds of file go through the same code: `smplx.SMPLX(path, use_pca=False, ...)`, the class that
`smplx.create` dispatches to. We call it directly because `smplx.create` picks the class from the file
*name* (the part before the first '_'), so it would refuse a user's file named e.g. `model.npz`; the
shipped mannequin is named `SMPLX_MANNEQUIN.npz` so that `smplx.create(path)` loads it too (tested). smplx 0.1.28
hard-codes SMPL-X's extra-joint vertex ids (up to 9929) and does not accept a `vertex_ids` argument for SMPL-X, so for a
file that carries its own (`vertex_id_names` / `vertex_id_values`, as the mannequin does) the module's
`vertex_joint_selector` is replaced by one built from them.

Hand poses: BEAT2 was fitted with MoSh++, whose body model (human_body_prior) uses hand rotations as they
are, relative to the flat open hand. So `flat_hand_mean=True` is the default: poses are absolute.
EMAGE's own renderers (PantoMatrix emage_utils) create SMPL-X with the default `flat_hand_mean=False`,
which adds SMPL-X's relaxed mean hand on top (more curled fingers); pass `flat_hand_mean=False` to match
those videos with the real model. The mannequin's hand mean is zero, so the flag changes nothing for it.

BEAT2 `poses` columns (SMPL-X joint order): global_orient 0:3, body_pose 3:66, jaw 66:69, left eye 69:72,
right eye 72:75, left hand 75:120, right hand 120:165. Units: metres, y up, the body faces +z.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
import torch

from ..motion.rotations import axis_angle_to_matrix
from ..motion.sequence import MotionSequence
from ..motion.skeleton import NUM_JOINTS
from .fk import forward_kinematics, forward_kinematics_aa, skinning_transforms
from .model_file import HINT, BodyModelError, resolve_model_path, used_dims, validate_model_file

__all__ = ["BodyModel", "BodyModelError", "BodyOutput", "load_body_model", "resolve_body", "resolve_model_path"]


@dataclass
class BodyOutput:
    vertices: np.ndarray    # (T, V, 3) float32, metres, world (trans applied)
    joints: np.ndarray      # (T, 55, 3) float32


class BodyModel:
    """An SMPL-X body with numpy-friendly, chunked posing.

    `forward` evaluates SMPL-X's function itself (blend shapes, pose correctives, forward kinematics,
    linear blend skinning) on the smplx module's buffers; it equals `forward_smplx` (the smplx module's own
    forward, kept as the reference) to float precision but avoids smplx's per-call overhead (mostly tiny
    batched matmuls; its size: docs/BENCHMARKS.md, "Why the code is built this way").
    """

    def __init__(self, module: torch.nn.Module, path: Path, flat_hand_mean: bool):
        self.module = module.eval()
        self.path = path
        self.flat_hand_mean = flat_hand_mean
        self.faces = np.asarray(module.faces, dtype=np.int64)                  # (F, 3)
        self.parents = tuple(int(p) for p in module.parents.tolist())
        self.num_betas = int(module.num_betas)
        self.num_expressions = int(module.num_expression_coeffs)
        self._dirs = torch.cat([module.shapedirs, module.expr_dirs], -1)        # (V, 3, B + E)
        self._posedirs = module.posedirs if bool(module.posedirs.abs().max() > 0) else None  # (486, 3V)
        self._cache: tuple[torch.Tensor, torch.Tensor, torch.Tensor] | None = None
        self._joint_dirs: tuple[torch.Tensor, torch.Tensor] | None = None

    @property
    def num_vertices(self) -> int:
        return int(self.module.v_template.shape[0])

    def _shape_coeffs(self, betas: np.ndarray | torch.Tensor | None, expressions=None) -> torch.Tensor:
        """(B, num_betas + num_expressions) from betas (any length, truncated/padded) and expressions."""
        b = torch.zeros(1, self.num_betas)
        if betas is not None:
            bt = torch.as_tensor(np.asarray(betas, np.float32)).reshape(-1)[: self.num_betas]
            b[0, : len(bt)] = bt
        if expressions is None:
            e = torch.zeros(1, self.num_expressions)
        else:
            e = torch.as_tensor(np.asarray(expressions, np.float32))
            e = e.reshape(-1, e.shape[-1])[:, : self.num_expressions]
            e = torch.nn.functional.pad(e, (0, self.num_expressions - e.shape[1]))
        return torch.cat([b.expand(len(e), -1), e], -1)

    def _shaped(self, coeffs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Shaped rest vertices (B, V, 3) and their joints (B, 55, 3); the last single shape is cached."""
        if len(coeffs) == 1 and self._cache is not None and torch.equal(self._cache[0], coeffs):
            return self._cache[1], self._cache[2]
        m = self.module
        v = m.v_template + torch.einsum("bl,vkl->bvk", coeffs, self._dirs)      # (B, V, 3)
        J = torch.einsum("jv,bvk->bjk", m.J_regressor, v)                        # (B, 55, 3)
        if len(coeffs) == 1:
            self._cache = (coeffs.clone(), v, J)
        return v, J

    @torch.no_grad()
    def rest_joints(self, betas=None, expressions=None) -> np.ndarray:
        """(55, 3) rest-pose joints for betas (and one expression vector), metres."""
        return self._shaped(self._shape_coeffs(betas, expressions))[1][0].numpy()

    @torch.no_grad()
    def rest_vertices(self, betas=None) -> np.ndarray:
        """(V, 3) the rest-pose mesh for betas, metres (its lowest vertex is the sole the rest pose stands on)."""
        return self._shaped(self._shape_coeffs(betas))[0][0].numpy()

    def _full_pose(self, poses: torch.Tensor) -> torch.Tensor:
        return poses + self.module.pose_mean.to(poses)                          # adds the hand mean if any

    @torch.no_grad()
    def joints(self, poses, trans, betas=None, expressions=None) -> np.ndarray:
        """(T, 55, 3) posed joints by forward kinematics only (no mesh): fast, equals forward().joints."""
        p = self._full_pose(torch.as_tensor(np.asarray(poses, np.float32)).reshape(-1, NUM_JOINTS * 3))
        t = torch.as_tensor(np.asarray(trans, np.float32)).reshape(-1, 3)
        rest = self._shaped(self._shape_coeffs(betas, expressions))[1]          # (1 or T, 55, 3)
        return forward_kinematics_aa(p, rest, self.parents, t)[0].numpy()

    def _pose_chunk(self, p: torch.Tensor, t: torch.Tensor, coeffs: torch.Tensor) -> tuple[torch.Tensor, ...]:
        """p (B, 165) axis-angle, t (B, 3), coeffs (1 or B, nb + ne) -> vertices (B, V, 3), joints (B, 55, 3)."""
        B, V = len(p), self.num_vertices
        R = axis_angle_to_matrix(self._full_pose(p).reshape(B, NUM_JOINTS, 3))  # (B, 55, 3, 3)
        v, J = self._shaped(coeffs)                                              # (1|B, V, 3), (1|B, 55, 3)
        if self._posedirs is not None:                                           # pose correctives
            feat = (R[:, 1:] - torch.eye(3)).reshape(B, -1)                      # (B, 486)
            v = v + (feat @ self._posedirs).reshape(B, V, 3)
        joints, G = forward_kinematics(R, J.expand(B, -1, -1), self.parents)
        A = skinning_transforms(G, J)[:, :, :3, :].reshape(B, NUM_JOINTS, 12)  # (B, 55, 12)
        M = (self.module.lbs_weights @ A).reshape(B, V, 3, 4)                   # (B, V, 3, 4) blended
        verts = (M[..., :3] * v[:, :, None, :]).sum(-1) + M[..., 3]             # (B, V, 3)
        return verts + t[:, None], joints + t[:, None]

    @torch.no_grad()
    def forward(self, poses, trans, expressions=None, betas=None, chunk: int = 128) -> BodyOutput:
        """Pose the mesh: poses (T, 165) axis-angle, trans (T, 3), expressions (T, E) or None, betas or None.

        Works through the frames `chunk` at a time, so memory stays bounded for long sequences.
        """
        P = np.asarray(poses, np.float32).reshape(-1, NUM_JOINTS * 3)
        T = len(P)
        tr = np.asarray(trans, np.float32).reshape(T, 3)
        verts = np.empty((T, self.num_vertices, 3), np.float32)
        joints = np.empty((T, NUM_JOINTS, 3), np.float32)
        still = self._shape_coeffs(betas)                                        # (1, nb + ne), no expression
        for s in range(0, T, chunk):
            p = torch.from_numpy(P[s:s + chunk])                                 # (B, 165)
            coeffs = still if expressions is None else self._shape_coeffs(betas, np.asarray(expressions)[s:s + chunk])
            v, j = self._pose_chunk(p, torch.from_numpy(tr[s:s + chunk]), coeffs)
            verts[s:s + len(p)] = v.numpy()
            joints[s:s + len(p)] = j.numpy()
        return BodyOutput(verts, joints)

    @torch.no_grad()
    def forward_smplx(self, poses, trans, expressions=None, betas=None) -> BodyOutput:
        """The smplx module's own forward (the reference `forward` is tested against); one batch."""
        p = torch.as_tensor(np.asarray(poses, np.float32)).reshape(-1, NUM_JOINTS * 3)
        B = len(p)
        c = self._shape_coeffs(betas, None if expressions is None else np.asarray(expressions))
        c = c.expand(B, -1)
        out = self.module(betas=c[:, : self.num_betas], expression=c[:, self.num_betas:], global_orient=p[:, :3],
                          body_pose=p[:, 3:66], jaw_pose=p[:, 66:69], leye_pose=p[:, 69:72],
                          reye_pose=p[:, 72:75], left_hand_pose=p[:, 75:120], right_hand_pose=p[:, 120:165],
                          transl=torch.as_tensor(np.asarray(trans, np.float32)).reshape(B, 3), return_shaped=False)
        return BodyOutput(out.vertices.numpy(), out.joints[:, :NUM_JOINTS].numpy())

    @torch.no_grad()
    def forward_subset(self, vertices: np.ndarray, poses, expressions=None, betas=None) -> np.ndarray:
        """(T, len(vertices), 3) the posed positions of only those vertex indices (no translation): what
        `forward(...).vertices[:, vertices]` gives, at a fraction of the cost when few vertices are needed
        (e.g. facial landmarks over every frame of a take)."""
        idx = torch.as_tensor(np.asarray(vertices, np.int64))
        p = self._full_pose(torch.as_tensor(np.asarray(poses, np.float32)).reshape(-1, NUM_JOINTS * 3))
        B, m = len(p), self.module
        c = self._shape_coeffs(betas, None if expressions is None else np.asarray(expressions)).expand(B, -1)
        v = m.v_template[idx] + torch.einsum("bl,vkl->bvk", c, self._dirs[idx])         # (B, n, 3)
        if self._joint_dirs is None:                   # joints are linear in the coefficients too
            self._joint_dirs = (m.J_regressor @ m.v_template, torch.einsum("jv,vkl->jkl", m.J_regressor, self._dirs))
        J = self._joint_dirs[0][None] + torch.einsum("bl,jkl->bjk", c, self._joint_dirs[1])
        R = axis_angle_to_matrix(p.reshape(B, NUM_JOINTS, 3))
        if self._posedirs is not None:
            cols = (3 * idx[:, None] + torch.arange(3)[None]).reshape(-1)
            v = v + ((R[:, 1:] - torch.eye(3)).reshape(B, -1) @ self._posedirs[:, cols]).reshape(B, len(idx), 3)
        _, G = forward_kinematics(R, J, self.parents)
        A = skinning_transforms(G, J)[:, :, :3, :].reshape(B, NUM_JOINTS, 12)
        M = (m.lbs_weights[idx] @ A).reshape(B, len(idx), 3, 4)
        return ((M[..., :3] * v[:, :, None, :]).sum(-1) + M[..., 3]).numpy()

    def forward_sequence(self, seq: MotionSequence, chunk: int = 128) -> BodyOutput:
        return self.forward(seq.poses, seq.trans, seq.expressions, seq.betas, chunk=chunk)

    @torch.no_grad()
    def height(self, betas=None) -> float:
        """Standing height of the rest mesh (max y - min y), metres."""
        v = self._shaped(self._shape_coeffs(betas))[0][0]
        return float(v[:, 1].max() - v[:, 1].min())


def load_body_model(path: str | Path | None = None, *, num_betas: int | None = None,
                    num_expressions: int | None = None, flat_hand_mean: bool = True) -> BodyModel:
    """Load an SMPL-X npz (see the module docstring for path resolution and the hand-mean choice).

    num_betas / num_expressions: how many shape / expression coefficients to use; None = all directions
    the file actually uses (300 / 100 for SMPL-X 2020; the mannequin's few), which gives identical results
    to 300 / 100 and is much faster per call. Extra coefficients passed to `forward` are ignored.
    """
    import smplx
    from smplx.vertex_joint_selector import VertexJointSelector

    p = resolve_model_path(path)
    validate_model_file(p)
    if num_betas is None or num_expressions is None:
        auto_b, auto_e = used_dims(p)
        num_betas = auto_b if num_betas is None else num_betas
        num_expressions = auto_e if num_expressions is None else num_expressions
    try:
        module = smplx.SMPLX(str(p), ext="npz", use_pca=False, flat_hand_mean=flat_hand_mean,
                             num_betas=num_betas, num_expression_coeffs=num_expressions, use_face_contour=False)
    except Exception as exc:  # anything smplx trips on after our checks
        raise BodyModelError(f"{p}: smplx could not load it ({type(exc).__name__}: {exc}) — {HINT}") from None
    with np.load(p, allow_pickle=False) as data:
        if "vertex_id_names" in data.files and "vertex_id_values" in data.files:
            ids = {str(k): int(v) for k, v in zip(data["vertex_id_names"], data["vertex_id_values"])}
            try:
                module.vertex_joint_selector = VertexJointSelector(vertex_ids=ids)
            except KeyError as exc:
                raise BodyModelError(f"{p}: 'vertex_id_names' lacks {exc} (smplx needs nose, eyes, ears, "
                                     "toes, heels and finger tips)") from None
    return BodyModel(module, p, flat_hand_mean)


@lru_cache(maxsize=4)
def _load_cached(path: str) -> BodyModel:
    return load_body_model(path)


def resolve_body(body: BodyModel | str | Path | None = None) -> BodyModel:
    """A BodyModel, a path to an SMPL-X npz, or None ($GESTURELSM_SMPLX_MODEL or the mannequin); loaded models
    are cached by path (rendering and every export of a request share one)."""
    if body is None or isinstance(body, (str, Path)):
        return _load_cached(str(resolve_model_path(body)))
    return body
