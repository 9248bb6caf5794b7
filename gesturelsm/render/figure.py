"""What a tile draws: the SMPL-X body (`BodyFigure`, the mannequin by default) or the user's character's own
mesh (`CharacterFigure`), both posed by the same SMPL-X motions, in the renderer's world (metres, y up, the
figure facing +z, its left on +x).

    figure = make_figure(seqs, body=None, character=None)      # a retarget.Character with a mesh -> its mesh
    posed = figure.pose(0, frame_ids)                          # Posed: vertices (n, V, 3), normals, root_xz

A character is retargeted (`retarget_motion`, its feet planted on its own legs unless `grounding` is off), its
meshes skinned per frame in numpy (`retarget.skinning`), its VRM mouth and blink expressions set from the
generated face (`retarget.face`), and its world turned into
the renderer's with the retargeting's alignment (left, up, forward -> +x, +y, +z); glTF units are metres.
A character without a mesh (a BVH skeleton, a glTF of bones only) is drawn as the mannequin, with a note. The camera
is fitted to `frame_points`: every vertex, or for a character of over FRAMING_VERTICES an even subset of them.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..motion.sequence import MotionSequence
from ..retarget import Character, retarget_motion
from ..retarget.face import driven_presets, face_weights, morph_weights
from ..retarget.mesh import CharacterMesh, character_mesh, has_mesh
from ..retarget.skinning import joint_world, pose_mesh, rest_world
from .surfaces import Surface

FRAMING_VERTICES = 100_000    # a character with more is framed from an even subset of this many (memory, time)


@dataclass
class Posed:
    vertices: np.ndarray            # (n, V, 3) float32, metres, the renderer's world
    normals: np.ndarray | None      # (n, V, 3) float32 unit normals, or None (computed from the triangles)
    root_xz: np.ndarray             # (n, 2) where each frame's contact shadow is centred


class BodyFigure:
    """The SMPL-X body model (`body.model.BodyModel`) in the style's body colour."""

    def __init__(self, body, seqs: list[MotionSequence]):
        self.body, self.seqs = body, seqs
        self.faces = np.asarray(body.faces, np.int64)
        self.num_vertices = self.framing_vertices = int(body.num_vertices)
        self.surfaces: list[Surface] | None = None
        self.notes: list[str] = []

    def pose(self, k: int, ids: np.ndarray) -> Posed:
        q = self.seqs[k]
        out = self.body.forward(q.poses[ids], q.trans[ids], q.expressions[ids], q.betas)
        return Posed(out.vertices, None, out.joints[:, 0, [0, 2]])

    def frame_points(self, k: int, ids: np.ndarray) -> np.ndarray:
        """(n, V, 3) the vertices the camera is fitted to (all of them)."""
        return self.pose(k, ids).vertices

    def hips_y(self, k: int) -> float:
        s = self.seqs[k]
        return float(self.body.joints(s.poses[:1], s.trans[:1], s.betas)[0, 0, 1])

    def rest_vertices(self) -> np.ndarray:
        return self.body.forward(np.zeros((1, 165)), np.zeros((1, 3)), betas=self.seqs[0].betas).vertices[0]


class CharacterFigure:
    """A character's own meshes (every triangle primitive, its materials and textures), skinned per frame."""

    def __init__(self, character: Character, seqs: list[MotionSequence], body=None, grounding: bool = True):
        from ..body.model import resolve_body

        doc = character.document
        body = resolve_body(body)
        self.seqs = seqs
        self.results = [retarget_motion(s, character, body, grounding=grounding) for s in seqs]
        self.mesh = character_mesh(doc, character.skeleton)
        self.notes = [f"{character.name}: {n}" for n in self.mesh.notes]
        self.notes += sorted({r.note for r in self.results if r.note})
        self.align = self.results[0].align                            # the character's world -> +x left, +y up
        presets = driven_presets(doc.gltf)
        self.morph = [morph_weights(doc.gltf, {p: w for p, w in face_weights(body, s.poses, s.expressions,
                                                                             s.betas).items() if p in presets})
                      if presets else {} for s in seqs]
        parts = self.mesh.parts
        self._own = [i for i, p in enumerate(parts) if p.shares < 0]         # the parts skinned (vertex owners)
        starts = dict(zip(self._own, np.cumsum([0] + [len(parts[i].positions) for i in self._own]).tolist()))
        start = [starts[i if p.shares < 0 else p.shares] for i, p in enumerate(parts)]
        self.num_vertices = self.mesh.num_vertices
        self.faces = np.concatenate([p.faces + s for p, s in zip(parts, start)])
        self.surfaces = [Surface(int(s), len(p.positions), p.faces, p.color, p.texture, p.uv, p.wrap, p.alpha_mode,
                                 p.alpha_cutoff, p.double_sided, roughness=0.6) for p, s in zip(parts, start)]
        self._normals = all(p.normals is not None for p in parts)
        self._framing = _thinned(self.mesh, -(-self.num_vertices // FRAMING_VERTICES))
        self.framing_vertices = self.num_vertices if self._framing is None else self._framing.num_vertices

    def _frame(self, world: np.ndarray, morph: dict[int, np.ndarray]) -> tuple[np.ndarray, np.ndarray | None]:
        verts, normals = pose_mesh(self.mesh, world, morph)
        v = np.concatenate([verts[i] for i in self._own]) @ self.align.T
        n = np.concatenate([normals[i] for i in self._own]) @ self.align.T if self._normals else None
        return v, n

    def pose(self, k: int, ids: np.ndarray) -> Posed:
        ids = np.asarray(ids, np.int64)
        r = self.results[k]
        W = joint_world(r, ids)
        V = np.empty((len(ids), self.num_vertices, 3), np.float32)
        N = np.empty_like(V) if self._normals else None
        for j, f in enumerate(ids):                                   # frame by frame into the float32 arrays
            V[j], n = self._frame(W[j], {m: w[f] for m, w in self.morph[k].items()})
            if N is not None:
                N[j] = n
        root = r.positions[ids, r.root] @ self.align.T
        return Posed(V, N, root[:, [0, 2]])

    def frame_points(self, k: int, ids: np.ndarray) -> np.ndarray:
        """(n, framing_vertices, 3) float32: the vertices the camera is fitted to at frames `ids` (all of them, or
        an even subset of a character with over FRAMING_VERTICES)."""
        if self._framing is None:
            return self.pose(k, ids).vertices
        ids = np.asarray(ids, np.int64)
        W = joint_world(self.results[k], ids)
        out = np.empty((len(ids), self.framing_vertices, 3), np.float32)
        for j, f in enumerate(ids):
            verts, _ = pose_mesh(self._framing, W[j], {m: w[f] for m, w in self.morph[k].items()})
            out[j] = np.concatenate(verts) @ self.align.T
        return out

    def hips_y(self, k: int) -> float:
        r = self.results[k]
        return float((r.positions[0, r.root] @ self.align.T)[1])

    def rest_vertices(self) -> np.ndarray:
        return self._frame(rest_world(self.results[0].skeleton), {})[0]


def _thinned(mesh: CharacterMesh, step: int) -> CharacterMesh | None:
    """Every `step`-th vertex of each skinned part (no triangles, normals or textures: points to frame the camera
    on); None for step 1."""
    if step <= 1:
        return None
    parts = [replace(p, positions=p.positions[::step], normals=None, faces=np.zeros((0, 3), np.int64), uv=None,
                     texture=None, target_normals=None,
                     joints=None if p.joints is None else p.joints[::step],
                     weights=None if p.weights is None else p.weights[::step],
                     targets=None if p.targets is None else p.targets[:, ::step]) for p in mesh.parts if p.shares < 0]
    return CharacterMesh(parts)


def make_figure(seqs: list[MotionSequence], body=None, character: Character | None = None, grounding: bool = True):
    """CharacterFigure for a character with a mesh (its feet planted on its own legs unless `grounding` is off),
    else BodyFigure (the body model, mannequin by default; with a note in `notes` when a character without a mesh
    was given)."""
    from ..body.model import resolve_body

    if character is not None and has_mesh(character.document):
        return CharacterFigure(character, seqs, body, grounding)
    figure = BodyFigure(resolve_body(body), seqs)
    if character is not None:
        figure.notes.append(f"{character.name}: a skeleton without a mesh; drawn as the mannequin")
    return figure
