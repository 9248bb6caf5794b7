"""A character's drawable meshes from its glTF / VRM document: every triangle primitive of every mesh node in
the scene, with what skinning needs (bind-pose positions and normals, JOINTS_0 / WEIGHTS_0 as the skeleton's
joint indices, the skin's inverse bind matrices, morph targets) and what drawing needs (indices, TEXCOORD_0,
the material's base colour factor and base colour texture).

    mesh = character_mesh(doc, skeleton)         # CharacterMesh: parts (MeshPart) + notes
    mesh.parts[0].positions, .joints, .weights, .inverse_bind, .faces, .color, .texture, .uv

Primitives of one mesh that share their vertex attributes (one primitive per material over a common vertex
buffer, as VRM exporters write them) are skinned once (`MeshPart.shares`). A mesh node without a skin moves
rigidly with its nearest ancestor among the skeleton's joints (an accessory parented to a bone); with none, it
stays at its rest place. Materials and textures: `textures.py` (a texture that cannot be decoded leaves the
material's colour and a note). Before anything is decoded, the scene's primitives, vertices, triangles and
morph targets are counted from the JSON against `limits.py` (`drawn_primitives`).
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field, replace

import numpy as np

from .accessors import accessor
from .errors import CharacterError
from .gltf import GltfDocument, node_trs
from .limits import MAX_MORPH_VALUES, MAX_PRIMITIVES, MAX_TRIANGLES, MAX_VERTICES, count
from .skeleton import Skeleton, trs_matrix
from .textures import Textures

TRIANGLES = 4


@dataclass
class MeshPart:
    """One triangle primitive, ready to skin and draw. Joint indices are the skeleton's (Skeleton order)."""
    name: str
    mesh: int                                   # glTF mesh index (morph weights are per mesh)
    positions: np.ndarray                       # (V, 3) bind pose, the mesh's own space
    normals: np.ndarray | None                  # (V, 3) or None (then computed from the triangles)
    faces: np.ndarray                           # (F, 3) int
    joints: np.ndarray | None = None            # (V, 4) skeleton joint indices; None: rigid
    weights: np.ndarray | None = None           # (V, 4) normalised
    inverse_bind: np.ndarray | None = None      # (J, 4, 4) one per skin joint
    skin_joints: np.ndarray | None = None       # (J,) skeleton joint index of each skin joint
    rigid_joint: int = -1                       # unskinned: the skeleton joint it follows (-1: none)
    rigid_offset: np.ndarray = field(default_factory=lambda: np.eye(4))   # joint's rest world^-1 @ node's
    targets: np.ndarray | None = None           # (K, V, 3) float32 morph target position deltas
    target_normals: np.ndarray | None = None    # (K, V, 3) float32 morph target normal deltas
    color: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0)    # linear base colour factor
    texture: np.ndarray | None = None           # (H, W, 4) uint8 base colour texture (sRGB)
    uv: np.ndarray | None = None                # (V, 2) TEXCOORD_0, glTF convention (v down)
    wrap: tuple[int, int] = (10497, 10497)      # glTF sampler wrapS, wrapT
    alpha_mode: str = "OPAQUE"                  # OPAQUE | MASK | BLEND
    alpha_cutoff: float = 0.5
    double_sided: bool = False
    shares: int = -1                            # >= 0: draws the vertices of that earlier part (same attributes)


@dataclass
class CharacterMesh:
    parts: list[MeshPart]
    notes: list[str] = field(default_factory=list)   # what was drawn differently from the file (textures)

    @property
    def num_vertices(self) -> int:
        """Vertices to skin per frame (parts that share another's vertices add none)."""
        return sum(len(p.positions) for p in self.parts if p.shares < 0)


def _scene_nodes(g: dict) -> list[tuple[int, np.ndarray]]:
    """(node, rest world matrix) of every node reachable from the scene (all root nodes without a scene)."""
    nodes = g.get("nodes") or []
    scenes = g.get("scenes") or []
    if scenes:
        roots = scenes[int(g.get("scene", 0) or 0)].get("nodes", [])
    else:
        kids = {c for nd in nodes for c in nd.get("children", []) or []}
        roots = [i for i in range(len(nodes)) if i not in kids]
    out, stack, seen = [], [(int(r), np.eye(4)) for r in roots], set()
    while stack:
        n, parent = stack.pop()
        if n in seen or not 0 <= n < len(nodes):
            continue
        seen.add(n)
        world = parent @ trs_matrix(*node_trs(nodes[n]))
        out.append((n, world))
        stack += [(int(c), world) for c in nodes[n].get("children", []) or []]
    return out


def has_mesh(doc: GltfDocument | None) -> bool:
    """Whether the document's scene has a triangle primitive to draw (a skeleton-only file has none)."""
    if doc is None:
        return False
    g = doc.gltf
    meshes = g.get("meshes") or []
    for n, _ in _scene_nodes(g):
        m = g["nodes"][n].get("mesh")
        if isinstance(m, int) and 0 <= m < len(meshes) and any(
                int(p.get("mode", TRIANGLES)) == TRIANGLES and "POSITION" in p.get("attributes", {})
                for p in meshes[m].get("primitives", [])):
            return True
    return False


@dataclass
class _Drawn:
    """One triangle primitive of one mesh node, as the scene draws it."""
    node: int
    world: np.ndarray              # the node's rest world matrix
    mesh: int
    index: int                     # the primitive's index in its mesh
    prim: dict
    key: tuple                     # primitives with equal keys share their vertices


VERTEX_TYPES = {"POSITION": "VEC3", "NORMAL": "VEC3", "TEXCOORD_0": "VEC2", "JOINTS_0": "VEC4", "WEIGHTS_0": "VEC4"}


def drawn_primitives(doc: GltfDocument) -> list[_Drawn]:
    """Every triangle primitive the document's scene draws, after checking from the JSON alone (before anything is
    decoded) that the vertex attributes agree (types, counts) and that the whole stays within the limits
    (`limits.py`: primitives, vertices, triangles, morph-target values); CharacterError otherwise."""
    g, src = doc.gltf, doc.source
    acc = g.get("accessors") or []
    out: list[_Drawn] = []
    shared: set[tuple] = set()
    vertices = triangles = morphs = 0
    for n, world in _scene_nodes(g):
        node = g["nodes"][n]
        if "mesh" not in node:
            continue
        if not np.isfinite(world).all():
            raise CharacterError(f"{src}: node {n}'s place in the scene is not finite (its ancestors' transforms "
                                 "multiply past the range of numbers)")
        m, skin = int(node["mesh"]), node.get("skin")
        for k, prim in enumerate(g["meshes"][m].get("primitives", [])):
            if int(prim.get("mode", TRIANGLES)) != TRIANGLES or "POSITION" not in prim.get("attributes", {}):
                continue
            key = (m, skin if skin is not None else -1 - n, tuple(sorted(prim["attributes"].items())),
                   json.dumps(prim.get("targets") or [], sort_keys=True))
            V = int(acc[prim["attributes"]["POSITION"]]["count"])
            if key not in shared:
                shared.add(key)
                _check_attributes(doc, prim, f"mesh {m} primitive {k}", V)
                vertices += V
                morphs += V * len(prim.get("targets") or [])
            triangles += (int(acc[prim["indices"]]["count"]) if "indices" in prim else V) // 3
            out.append(_Drawn(n, world, m, k, prim, key))
    for what, have, limit in (("triangle primitives", len(out), MAX_PRIMITIVES), ("vertices", vertices, MAX_VERTICES),
                              ("triangles", triangles, MAX_TRIANGLES),
                              ("morph-target values (targets x vertices)", morphs, MAX_MORPH_VALUES)):
        if have > limit:
            raise CharacterError(f"{src}: its scene draws {count(have)} {what}; a character may have at most "
                                 f"{count(limit)}")
    return out


def _check_attributes(doc: GltfDocument, prim: dict, what: str, V: int) -> None:
    """The vertex attributes and morph targets read for drawing have the glTF type of their kind and V elements."""
    acc = doc.gltf.get("accessors") or []
    for group in [prim["attributes"]] + list(prim.get("targets") or []):
        for name, want in VERTEX_TYPES.items():
            if name not in group:
                continue
            a = acc[group[name]]
            if a["type"] != want or int(a["count"]) != V:
                raise CharacterError(f"{doc.source}: {what}'s {name} is {count(int(a['count']))} {a['type']} "
                                     f"elements; {count(V)} {want} (one per vertex) are needed")


def character_mesh(doc: GltfDocument, skel: Skeleton, textures: bool = True) -> CharacterMesh:
    """Every drawable triangle primitive of the document's scene (module docstring), within the limits
    (`drawn_primitives`); CharacterError when the file has none. textures=False: no image is decoded (the
    geometry and material colours only)."""
    g, src = doc.gltf, doc.source
    joint_of = {node: i for i, node in enumerate(skel.nodes)}
    parents_of = {int(c): i for i, nd in enumerate(g.get("nodes") or []) for c in nd.get("children", []) or []}
    rest = skel.world()
    materials = Textures(doc, decode=textures)
    parts: list[MeshPart] = []
    first: dict[tuple, int] = {}            # primitives sharing vertex attributes are skinned once
    for d in drawn_primitives(doc):
        skin, prim, m = g["nodes"][d.node].get("skin"), d.prim, d.mesh
        name = f"{g['meshes'][m].get('name', f'mesh{m}')}[{d.index}]"
        if d.key in first:                      # the same vertices as an earlier primitive, other triangles
            owner = parts[first[d.key]]
            part = replace(owner, name=name, faces=_faces(doc, prim, name, len(owner.positions)),
                           shares=first[d.key])
            materials.material(part, prim.get("material"))
            parts.append(part)
            continue
        part = _part(doc, prim, name, m, materials)
        if skin is not None:
            _attach_skin(doc, part, prim, g["skins"][int(skin)], joint_of)
        else:
            part.rigid_joint, part.rigid_offset = _rigid(d, parents_of, joint_of, rest)
        first[d.key] = len(parts)
        parts.append(part)
    if not parts:
        raise CharacterError(f"{src}: the file has no triangle mesh to draw")
    return CharacterMesh(parts, materials.notes)


def _rigid(d: _Drawn, parents_of: dict[int, int], joint_of: dict[int, int], rest: np.ndarray
           ) -> tuple[int, np.ndarray]:
    """(the skeleton joint an unskinned mesh node follows, its offset from that joint's rest); (-1, its rest
    world matrix) when no ancestor is a joint."""
    a = parents_of.get(d.node)
    while a is not None and a not in joint_of:
        a = parents_of.get(a)
    if a is None:
        return -1, d.world
    return joint_of[a], np.linalg.inv(rest[joint_of[a]]) @ d.world


def _part(doc: GltfDocument, prim: dict, name: str, mesh: int, textures: "Textures") -> MeshPart:
    at = prim["attributes"]
    pos = accessor(doc, at["POSITION"]).astype(np.float64)
    V = len(pos)
    part = MeshPart(name, mesh, pos, accessor(doc, at["NORMAL"]).astype(np.float64) if "NORMAL" in at else None,
                    _faces(doc, prim, name, V))
    if "TEXCOORD_0" in at:
        part.uv = accessor(doc, at["TEXCOORD_0"]).astype(np.float32)
    targets = prim.get("targets") or []
    if targets:
        part.targets = np.stack([accessor(doc, t["POSITION"]).astype(np.float32) if "POSITION" in t
                                 else np.zeros((V, 3), np.float32) for t in targets])
        if part.normals is not None and any("NORMAL" in t for t in targets):
            part.target_normals = np.stack([accessor(doc, t["NORMAL"]).astype(np.float32) if "NORMAL" in t
                                            else np.zeros((V, 3), np.float32) for t in targets])
    textures.material(part, prim.get("material"))
    return part


def _faces(doc: GltfDocument, prim: dict, name: str, V: int) -> np.ndarray:
    """(F, 3) triangles of a primitive (its indices, or its vertices in order)."""
    if "indices" in prim:
        idx = accessor(doc, prim["indices"]).reshape(-1).astype(np.int64)
    else:
        idx = np.arange(V, dtype=np.int64)
    idx = idx[: len(idx) // 3 * 3]
    if idx.size and (idx.min() < 0 or idx.max() >= V):
        raise CharacterError(f"{doc.source}: mesh {name} has indices beyond its {V} vertices")
    return idx.reshape(-1, 3)


def _attach_skin(doc: GltfDocument, part: MeshPart, prim: dict, skin: dict, joint_of: dict[int, int]) -> None:
    at = prim["attributes"]
    if "JOINTS_0" not in at or "WEIGHTS_0" not in at:
        raise CharacterError(f"{doc.source}: the skinned mesh {part.name} has no JOINTS_0 / WEIGHTS_0")
    nodes = [int(j) for j in skin.get("joints", [])]
    part.skin_joints = np.array([joint_of[j] for j in nodes], np.int64)
    if "inverseBindMatrices" in skin:
        ibm = accessor(doc, skin["inverseBindMatrices"]).astype(np.float64)
        if ibm.shape[1] != 16:
            raise CharacterError(f"{doc.source}: a skin's inverseBindMatrices are not MAT4")
        part.inverse_bind = ibm.reshape(-1, 4, 4).transpose(0, 2, 1)           # column-major in glTF
    else:
        part.inverse_bind = np.tile(np.eye(4), (len(nodes), 1, 1))
    if len(part.inverse_bind) != len(nodes):
        raise CharacterError(f"{doc.source}: a skin has {len(nodes)} joints but {len(part.inverse_bind)} "
                             "inverse bind matrices")
    J = accessor(doc, at["JOINTS_0"]).astype(np.int64)
    W = accessor(doc, at["WEIGHTS_0"]).astype(np.float64)
    if J.size and (J.min() < 0 or J.max() >= len(nodes)):
        raise CharacterError(f"{doc.source}: mesh {part.name} names skin joints that do not exist")
    total = W.sum(1, keepdims=True)
    W = np.where(total > 1e-9, W / np.maximum(total, 1e-9), np.array([1.0, 0, 0, 0]))
    part.joints, part.weights = J, W
