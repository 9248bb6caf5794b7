"""Retargeting SMPL-X motion onto a character by matching world bone directions.

For each humanoid bone of the character (joint i, SMPL-X joint j) the solver finds its world rotation
relative to its rest pose, Δ_i, so that the bone's direction (joint -> next mapped joint down the chain)
points where SMPL-X's points in that frame:
* a bone with a chain: Δ_i = S(G_j c -> d) · G_j · S(e -> c), with G_j SMPL-X's world rotation of j, c and d
  SMPL-X's rest and posed chain directions, e the character's rest direction, S(a -> b) the shortest
  rotation. S(e -> c) absorbs the different rest pose (T / A pose, bent elbows); S(G_j c -> d) absorbs the
  rotations of joints the character lacks (a 2-segment spine follows spine1 -> spine3); G_j carries twist.
* the hips, the upper chest and the hands also match a secondary direction (left hip -> right hip,
  left collar -> right collar, index -> little finger): Δ_i = F(d, d2) F(e, e2)^T with F an orthonormal frame.
* a bone with no chain (head, hands without fingers, finger tips, toes) turns as SMPL-X's joint does, after
  the rest-pose correction of its nearest mapped ancestor.
* a joint with no humanoid bone keeps its rest rotation relative to its parent.
All of it happens in an aligned frame (the character's left, up and forward turned onto SMPL-X's +x, +y,
+z), so Y-up or Z-up, facing +z or -z, and each joint's own local axes do not matter. Local rotations
follow as L_i = W_p^-1 Δ_p^-1 Δ_i W_i (W: rest world rotations). The root moves as SMPL-X's pelvis scaled by
the ratio of leg lengths (so centimetre rigs move in centimetres), starting at the character's place, and
its height keeps the lowest foot joint as far above the character's floor as SMPL-X's is above its own.
Where the root starts and where SMPL-X's floor is come from the motion itself (its first frame, its lowest foot),
or from a `Ground` given by the caller: a stream retargeted chunk by chunk with its first chunk's `Ground` has
the same root motion as the whole stream at once (no jump at chunk borders).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..motion.rotations import axis_angle_to_matrix_np
from ..motion.skeleton import JOINT_INDEX, NUM_JOINTS, PARENTS
from .errors import CharacterError
from .skeleton import Skeleton, world_rotation
from .vectors import frame, rotation_between, unit

CHAIN: dict[str, tuple[str, ...]] = {
    "pelvis": ("spine1", "spine2", "spine3", "neck"), "spine1": ("spine2", "spine3", "neck"),
    "spine2": ("spine3", "neck"), "spine3": ("neck", "head"), "neck": ("head",),
}
PAIRS: dict[str, tuple[tuple[str, str], ...]] = {
    "pelvis": (("left_hip", "right_hip"),),
    "spine3": (("left_collar", "right_collar"), ("left_shoulder", "right_shoulder")),
}
for _s in ("left", "right"):
    CHAIN.update({f"{_s}_hip": (f"{_s}_knee", f"{_s}_ankle"), f"{_s}_knee": (f"{_s}_ankle",),
                  f"{_s}_ankle": (f"{_s}_foot",), f"{_s}_collar": (f"{_s}_shoulder", f"{_s}_elbow"),
                  f"{_s}_shoulder": (f"{_s}_elbow", f"{_s}_wrist"), f"{_s}_elbow": (f"{_s}_wrist",),
                  f"{_s}_wrist": tuple(f"{_s}_{f}1" for f in ("middle", "ring", "index", "pinky"))})
    PAIRS[f"{_s}_wrist"] = ((f"{_s}_index1", f"{_s}_pinky1"), (f"{_s}_index1", f"{_s}_ring1"),
                            (f"{_s}_middle1", f"{_s}_pinky1"))
    for _f in ("index", "middle", "ring", "pinky", "thumb"):
        CHAIN[f"{_s}_{_f}1"] = (f"{_s}_{_f}2", f"{_s}_{_f}3")
        CHAIN[f"{_s}_{_f}2"] = (f"{_s}_{_f}3",)
FEET = ("left_ankle", "right_ankle", "left_foot", "right_foot")


@dataclass
class SourceBody:
    """The SMPL-X body the motion is on: rest joints (55, 3) metres, and the pose mean its model adds."""
    rest_joints: np.ndarray
    pose_mean: np.ndarray = field(default_factory=lambda: np.zeros(NUM_JOINTS * 3))

    @classmethod
    def of(cls, body, betas=None) -> "SourceBody":
        return cls(np.asarray(body.rest_joints(betas), np.float64),
                   body.module.pose_mean.detach().cpu().numpy().astype(np.float64).reshape(-1))


@dataclass(frozen=True)
class Ground:
    """The reference of the root motion, in SMPL-X's world: `pelvis` (3,) is where SMPL-X's pelvis stands when the
    character's hips stand at their rest place, `floor` the height of SMPL-X's floor (its lowest foot joint there)."""
    pelvis: np.ndarray
    floor: float


@dataclass
class Retargeted:
    """A motion on a character (all arrays per frame, in the character's own world frame and units)."""
    skeleton: Skeleton
    fps: int
    aligned_delta: np.ndarray      # (T, N, 3, 3) rotation of each joint relative to its rest, `align`ed axes
    positions: np.ndarray          # (T, N, 3) world joint positions
    local_rotation: np.ndarray     # (T, N, 3, 3) local rotation of each joint (its file's convention)
    root: int                      # the hips joint, the one whose translation moves
    root_translation: np.ndarray   # (T, 3) the hips' local translation
    align: np.ndarray              # (3, 3) the character's world -> SMPL-X's axes (left +x, up +y, forward +z)
    scale: float                   # character units per SMPL-X metre (leg-length ratio)
    ground: Ground | None = None   # the root motion's reference (pass it on to continue a stream)
    note: str | None = None        # why its feet were not grounded on the character's legs (grounding.py), if asked

    @property
    def num_frames(self) -> int:
        return len(self.aligned_delta)

    @property
    def delta(self) -> np.ndarray:
        """(T, N, 3, 3) world rotation of each joint relative to its rest, in the character's world axes."""
        return self.align.T @ self.aligned_delta @ self.align


def _snap(v: np.ndarray, degrees: float = 25.0) -> np.ndarray:
    """v turned onto the nearest world axis (+-x, +-y, +-z) when within `degrees` of it, else unit(v): a
    character's head sits a little forward of its hips, yet its up is a world axis."""
    u = unit(v)
    k = int(np.argmax(np.abs(u)))
    if abs(u[k]) >= np.cos(np.radians(degrees)):
        u = np.zeros(3)
        u[k] = np.sign(v[k])
    return u


def alignment(skel: Skeleton, p: np.ndarray) -> np.ndarray:
    """(3, 3) rotation taking the character's rest world to SMPL-X's axes (rows: its left, up, forward),
    from its hips (left) and head (up), each snapped onto the nearest world axis when close to one."""
    b = skel.bones
    left = p[b["left_hip"]] - p[b["right_hip"]]
    up = p[b["head"]] - p[b["pelvis"]]
    if np.linalg.norm(left) < 1e-9 or np.linalg.norm(up) < 1e-9:
        raise CharacterError(f"{skel.source}: hips and head coincide; the rest pose is degenerate")
    F = frame(_snap(up)[None], _snap(left)[None])[0]   # columns: up, left (orthogonalised), up x left
    return np.stack([F[:, 1], F[:, 0], -F[:, 2]])       # rows: left, up, forward = left x up


def _leg(x: np.ndarray, idx: dict[str, int]) -> float:
    legs = [np.linalg.norm(x[idx[f"{s}_hip"]] - x[idx[f"{s}_knee"]]) +
            np.linalg.norm(x[idx[f"{s}_knee"]] - x[idx[f"{s}_ankle"]]) for s in ("left", "right")]
    return float(np.mean(legs))



def joint_depths(parents) -> np.ndarray:
    """Each joint's number of ancestors (parents[i] < i, -1 for a root)."""
    depth = np.zeros(len(parents), np.int64)
    for i, pp in enumerate(parents):
        depth[i] = 0 if pp < 0 else depth[pp] + 1
    return depth


_DEPTH = joint_depths(PARENTS)
_LEVELS = [np.nonzero(_DEPTH == d)[0] for d in range(int(_DEPTH.max()) + 1)]   # root first


def _smplx_fk(seq, src: SourceBody) -> tuple[np.ndarray, np.ndarray]:
    """SMPL-X's posed joints (T, 55, 3) (pelvis at its rest place) and world rotations (T, 55, 3, 3): one level
    of the tree at a time, in numpy (a stream's chunk of 20 frames costs well under a millisecond)."""
    T = seq.num_frames
    R = axis_angle_to_matrix_np((np.asarray(seq.poses, np.float64) + src.pose_mean).reshape(T, NUM_JOINTS, 3))
    rest = src.rest_joints
    par = np.asarray(PARENTS)
    G, P = np.empty((T, NUM_JOINTS, 3, 3)), np.empty((T, NUM_JOINTS, 3))
    G[:, _LEVELS[0]], P[:, _LEVELS[0]] = R[:, _LEVELS[0]], rest[_LEVELS[0]]
    for idx in _LEVELS[1:]:
        p = par[idx]
        G[:, idx] = G[:, p] @ R[:, idx]
        P[:, idx] = P[:, p] + np.einsum("tjxy,jy->tjx", G[:, p], rest[idx] - rest[p])
    return P, G


def _is_below(parents: np.ndarray, child: int, ancestor: int) -> bool:
    while child >= 0:
        child = int(parents[child])
        if child == ancestor:
            return True
    return False


@dataclass
class _Plan:
    """Per humanoid bone, what its Δ is made of (rest-pose data only; computed once per character)."""
    chain: list[tuple[int, int, int, np.ndarray, np.ndarray]]       # (i, j, child j, c unit, C)
    frames: list[tuple[int, int, int, int, int, np.ndarray]]        # (i, j, child j, pair a, pair b, Fe)
    leaves: list[tuple[int, int, np.ndarray]]                        # (i, j, C)
    copy_of: np.ndarray                                              # (N,) the bone whose Δ a joint takes; -1: none


def _plan(skel: Skeleton, q: np.ndarray, J: np.ndarray) -> _Plan:
    joint_of = {i: j for j, i in skel.bones.items()}
    corr: dict[int, np.ndarray] = {}
    chain, frames, leaves = [], [], []
    copy_of = np.full(len(skel), -1)
    for i in range(len(skel)):
        p = int(skel.parents[i])
        name = joint_of.get(i)
        if name is None:
            copy_of[i] = -1 if p < 0 else copy_of[p]
            if p in corr:
                corr[i] = corr[p]
            continue
        copy_of[i] = i
        j = JOINT_INDEX[name]
        kids = [c for c in CHAIN.get(name, ()) if c in skel.bones and _is_below(skel.parents, skel.bones[c], i)
                and np.linalg.norm(q[skel.bones[c]] - q[i]) > 1e-9]
        if not kids:
            corr[i] = corr.get(p, np.eye(3))
            leaves.append((i, j, corr[i]))
            continue
        jc, ic = JOINT_INDEX[kids[0]], skel.bones[kids[0]]
        e1, c1 = q[ic] - q[i], J[jc] - J[j]
        pair = next(((a, b) for a, b in PAIRS.get(name, ()) if a in skel.bones and b in skel.bones), None)
        if pair is not None:
            ja, jb = JOINT_INDEX[pair[0]], JOINT_INDEX[pair[1]]
            Fe = frame(e1[None], (q[skel.bones[pair[0]]] - q[skel.bones[pair[1]]])[None])[0]
            corr[i] = frame(c1[None], (J[ja] - J[jb])[None])[0] @ Fe.T
            frames.append((i, j, jc, ja, jb, Fe))
        else:
            corr[i] = rotation_between(unit(e1)[None], unit(c1)[None])[0]
            chain.append((i, j, jc, unit(c1), corr[i]))
    return _Plan(chain, frames, leaves, copy_of)


def _solve_deltas(skel: Skeleton, plan: _Plan, P: np.ndarray, G: np.ndarray) -> np.ndarray:
    """(T, N, 3, 3) world rotations relative to rest, in the aligned frame (see the module docstring); each
    kind of bone is solved for all its bones at once."""
    T, N = len(P), len(skel)
    delta = np.empty((T, N + 1, 3, 3))
    delta[:, N] = np.eye(3)                                          # the joints above every humanoid bone
    if plan.chain:
        i, j, jc, c, C = (np.array(x) for x in zip(*plan.chain))
        Gj = G[:, j]
        Gc = np.einsum("tbxy,by->tbx", Gj, c)
        delta[:, i] = rotation_between(Gc, unit(P[:, jc] - P[:, j])) @ Gj @ C
    if plan.frames:
        i, j, jc, ja, jb, Fe = (np.array(x) for x in zip(*plan.frames))
        delta[:, i] = frame(P[:, jc] - P[:, j], P[:, ja] - P[:, jb]) @ np.swapaxes(Fe, -1, -2)
    if plan.leaves:
        i, j, C = (np.array(x) for x in zip(*plan.leaves))
        delta[:, i] = G[:, j] @ C
    copy = np.where(plan.copy_of < 0, N, plan.copy_of)
    unmapped = np.nonzero(copy != np.arange(N))[0]
    delta[:, unmapped] = delta[:, copy[unmapped]]
    return delta[:, :N]


@dataclass
class Setup:
    """What retargeting onto `skel` from `source` needs of the two rest poses alone (`prepare`): computed once, it
    makes retargeting a stream chunk by chunk cost only the per-frame work."""
    skel: Skeleton
    source: SourceBody
    Mw: np.ndarray             # (N, 4, 4) rest world matrices
    W: np.ndarray              # (N, 3, 3) rest world rotations
    A: np.ndarray              # (3, 3) alignment
    q: np.ndarray              # (N, 3) rest positions, aligned frame
    scale: float
    plan: _Plan
    levels: list[np.ndarray]   # the joints of each depth of the tree below the roots, top down
    below: np.ndarray          # (N,) bool: the hips and the joints under them (they move with the root)
    Vbase: np.ndarray          # (3, 3) aligned world rotation above the roots
    to_parent: np.ndarray      # (4, 4) world -> the hips' parent's local frame


def prepare(skel: Skeleton, source: SourceBody) -> Setup:
    """The rest-pose part of `retarget` (an absurd scale raises CharacterError here)."""
    Mw = skel.world()
    p_rest, W = Mw[:, :3, 3], world_rotation(Mw)
    A = alignment(skel, p_rest)
    q = p_rest @ A.T                                                   # rest positions, aligned frame
    Jr = source.rest_joints
    scale = _leg(q, skel.bones) / _leg(Jr, JOINT_INDEX)
    if not 1e-3 <= scale <= 1e4:
        raise CharacterError(f"{skel.source}: absurd scale: the legs are {scale * _leg(Jr, JOINT_INDEX):.3g} "
                             "units long (a humanoid's are about 0.8 m, 80 cm or 800 mm)")
    depth = joint_depths(skel.parents)
    hips = skel.bones["pelvis"]
    below = np.array([i == hips or _is_below(skel.parents, i, hips) for i in range(len(skel))])
    parent_world = Mw[skel.parents[hips]] if skel.parents[hips] >= 0 else skel.base
    return Setup(skel, source, Mw, W, A, q, float(scale), _plan(skel, q, Jr),
                 [np.nonzero(depth == d)[0] for d in range(1, int(depth.max()) + 1)], below,
                 A @ world_rotation(skel.base), np.linalg.inv(parent_world))


def retarget(seq, skel: Skeleton, source: SourceBody, ground: Ground | None = None,
             setup: Setup | None = None) -> Retargeted:
    """Retarget `seq` (a MotionSequence on the SMPL-X body `source`) onto `skel` (module docstring); `ground`: the
    root motion's reference (None: the motion's first frame and lowest foot); `setup`: `prepare(skel, source)`,
    when the caller keeps it."""
    if setup is None or setup.skel is not skel or setup.source is not source:
        setup = prepare(skel, source)
    q, scale = setup.q, setup.scale
    P, G = _smplx_fk(seq, source)
    delta = _solve_deltas(skel, setup.plan, P, G)
    pos = rest_rooted(setup, delta)
    pelvis = P[:, 0] + np.asarray(seq.trans, np.float64)               # SMPL-X's pelvis in its world
    feet = [f for f in FEET if f in skel.bones]
    smplx_low = (P[:, [JOINT_INDEX[f] for f in feet], 1] + np.asarray(seq.trans, np.float64)[:, 1:2]).min(1)
    if ground is None:
        ground = Ground(pelvis[0].copy(), float(smplx_low.min()))
    disp = scale * (pelvis - ground.pelvis)
    lift = smplx_low - ground.floor                                   # SMPL-X's lowest foot above its floor
    rest_low = q[[skel.bones[f] for f in feet], 1].min()
    disp[:, 1] = rest_low + scale * lift - pos[:, [skel.bones[f] for f in feet], 1].min(1)
    pos[:, setup.below] += disp[:, None]
    return assemble(setup, delta, pos, int(seq.fps), ground)


def rest_rooted(setup: Setup, delta: np.ndarray) -> np.ndarray:
    """(T, N, 3) joint positions (aligned frame) for the rotations `delta` (T, N, 3, 3) with the roots at their rest
    place: each offset turns with its parent."""
    skel, q = setup.skel, setup.q
    pos = np.empty(delta.shape[:2] + (3,))
    roots = np.nonzero(skel.parents < 0)[0]
    pos[:, roots] = q[roots]
    for idx in setup.levels:                                          # one level of the tree at a time
        par = skel.parents[idx]
        pos[:, idx] = pos[:, par] + np.einsum("tnxy,ny->tnx", delta[:, par], q[idx] - q[par])
    return pos


def assemble(setup: Setup, delta: np.ndarray, pos: np.ndarray, fps: int, ground: Ground | None) -> Retargeted:
    """The Retargeted of aligned rotations relative to rest `delta` (T, N, 3, 3) and aligned joint positions `pos`
    (T, N, 3): each humanoid bone's and the hips' local rotation in its file's convention, the hips' translation."""
    skel, A = setup.skel, setup.A
    T, N = delta.shape[:2]
    hips = skel.bones["pelvis"]
    local = np.empty((T, N, 3, 3))
    local[:] = skel.rotation                     # joints that are no humanoid bone keep their rest rotation
    moving = moving_joints(setup)
    local[:, moving] = local_rotations(setup, delta, moving)
    pos_w = pos @ A
    return Retargeted(skel, fps, delta, pos_w, local, hips, root_translation(setup, pos_w), A, float(setup.scale),
                      ground)


def moving_joints(setup: Setup) -> np.ndarray:
    """The joints whose local rotation moves: the humanoid bones and the hips."""
    return np.array(sorted(set(setup.skel.bones.values()) | {setup.skel.bones["pelvis"]}))


def local_rotations(setup: Setup, delta: np.ndarray, joints: np.ndarray) -> np.ndarray:
    """(T, len(joints), 3, 3) local rotations of `joints` in their file's convention, from the aligned rotations
    relative to rest `delta` (T, N, 3, 3): L_i = W_p^-1 Δw_p^-1 Δw_i W_i = V_p^T Δ_p^T Δ_i V_i with V = A W the
    aligned rest rotations."""
    V, Vbase = setup.A @ setup.W, setup.Vbase
    par = setup.skel.parents[joints]
    Vp = np.where((par >= 0)[:, None, None], V[np.maximum(par, 0)], Vbase)
    dp = np.where((par >= 0)[None, :, None, None], delta[:, np.maximum(par, 0)], np.eye(3))
    return np.swapaxes(Vp, -1, -2) @ (np.swapaxes(dp, -1, -2) @ delta[:, joints]) @ V[joints]


def root_translation(setup: Setup, pos_w: np.ndarray) -> np.ndarray:
    """(T, 3) the hips' local translation for world joint positions `pos_w` (T, N, 3)."""
    hips = pos_w[:, setup.skel.bones["pelvis"]]
    return (setup.to_parent @ np.concatenate([hips, np.ones((len(hips), 1))], 1).T).T[:, :3]
