"""A character's drawable meshes from its glTF / VRM document: every triangle primitive of every mesh node in
the scene, with what skinning needs (bind-pose positions and normals, JOINTS_0 / WEIGHTS_0 as the skeleton's
joint indices, the skin's inverse bind matrices, morph targets) and what drawing needs (indices, TEXCOORD_0,
the material's base colour factor and base colour texture).

    mesh = character_mesh(doc, skeleton)         # CharacterMesh: parts (MeshPart) + notes
    mesh.parts[0].positions, .joints, .weights, .inverse_bind, .faces, .color, .texture, .uv

Primitives of one mesh that share their vertex attributes (one primitive per material over a common vertex
buffer, as VRM exporters write them) are skinned once (`MeshPart.shares`). A mesh node without a skin moves rigidly with its nearest ancestor among the skeleton's joints (an accessory
parented to a bone); with none, it stays at its rest place. A texture that cannot be decoded, or that lives in
a separate file, leaves the material's colour factor and a note (nothing fails). VRM 0.x materials whose glTF
entry has no texture take MToon's `_MainTex` / `_Color` from the VRM extension.
"""
from __future__ import annotations

import base64
import io
import json
from dataclasses import dataclass, field, replace

import numpy as np

from .errors import CharacterError
from .gltf import GltfDocument, node_trs
from .skeleton import Skeleton, trs_matrix

DTYPES = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
MAX_TEXELS = 1024                     # textures are shrunk to at most this many texels a side for drawing
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
    targets: np.ndarray | None = None           # (K, V, 3) morph target position deltas
    target_normals: np.ndarray | None = None    # (K, V, 3) morph target normal deltas
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


def accessor(doc: GltfDocument, index: int) -> np.ndarray:
    """(count, width) array of a glTF accessor (byteStride, sparse and normalised integers handled)."""
    g, src = doc.gltf, doc.source
    try:
        a = g["accessors"][int(index)]
        dtype, n, count = np.dtype(DTYPES[a["componentType"]]), WIDTH[a["type"]], int(a["count"])
    except (KeyError, IndexError, TypeError, ValueError):
        raise CharacterError(f"{src}: accessor {index} is damaged or missing") from None
    out = _view(doc, a.get("bufferView"), a.get("byteOffset", 0), dtype, n, count, f"accessor {index}") \
        if "bufferView" in a else np.zeros((count, n), dtype)
    sp = a.get("sparse")
    if sp:
        k = int(sp["count"])
        idx = _view(doc, sp["indices"]["bufferView"], sp["indices"].get("byteOffset", 0),
                    np.dtype(DTYPES[sp["indices"]["componentType"]]), 1, k, f"accessor {index}")[:, 0]
        vals = _view(doc, sp["values"]["bufferView"], sp["values"].get("byteOffset", 0), dtype, n, k,
                     f"accessor {index}")
        if idx.size and int(idx.max()) >= count:
            raise CharacterError(f"{src}: accessor {index}'s sparse indices exceed its count")
        out = out.copy()
        out[idx.astype(np.int64)] = vals
    if a.get("normalized") and dtype.kind in "iu":
        top = float(np.iinfo(dtype).max)
        return np.maximum(out.astype(np.float32) / top, -1.0)
    return out


def _view(doc: GltfDocument, view: int, offset: int, dtype: np.dtype, n: int, count: int, what: str) -> np.ndarray:
    try:
        v = doc.gltf["bufferViews"][int(view)]
        start = int(v.get("byteOffset", 0)) + int(offset)
        stride = int(v.get("byteStride") or dtype.itemsize * n)
        buffer = int(v.get("buffer", 0))
    except (KeyError, IndexError, TypeError, ValueError):
        raise CharacterError(f"{doc.source}: {what} names a damaged buffer view") from None
    if buffer != 0 or not doc.blob:
        raise CharacterError(f"{doc.source}: {what} is in a separate buffer file; use a self-contained .glb / .vrm")
    end = start + (stride * (count - 1) + dtype.itemsize * n if count else 0)
    if start < 0 or end > len(doc.blob):
        raise CharacterError(f"{doc.source}: {what} reaches past the end of the binary buffer (truncated file)")
    if count == 0:
        return np.zeros((0, n), dtype)
    return np.ndarray((count, n), dtype, buffer=doc.blob, offset=start, strides=(stride, dtype.itemsize)).copy()


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


def character_mesh(doc: GltfDocument, skel: Skeleton) -> CharacterMesh:
    """Every drawable triangle primitive of the document's scene (module docstring); CharacterError when the
    file has none."""
    g, src = doc.gltf, doc.source
    joint_of = {node: i for i, node in enumerate(skel.nodes)}
    parents_of = {int(c): i for i, nd in enumerate(g.get("nodes") or []) for c in nd.get("children", []) or []}
    rest = skel.world()
    textures = _Textures(doc)
    parts: list[MeshPart] = []
    first: dict[tuple, int] = {}            # primitives sharing vertex attributes are skinned once
    for n, world in _scene_nodes(g):
        node = g["nodes"][n]
        if "mesh" not in node:
            continue
        m = int(node["mesh"])
        skin = node.get("skin")
        rigid, offset = -1, world
        if skin is None:
            a = parents_of.get(n)
            while a is not None and a not in joint_of:
                a = parents_of.get(a)
            if a is not None:
                rigid = joint_of[a]
                offset = np.linalg.inv(rest[rigid]) @ world
        for k, prim in enumerate(g["meshes"][m].get("primitives", [])):
            if int(prim.get("mode", TRIANGLES)) != TRIANGLES or "POSITION" not in prim.get("attributes", {}):
                continue
            name = f"{g['meshes'][m].get('name', f'mesh{m}')}[{k}]"
            key = (m, skin if skin is not None else -1 - n, tuple(sorted(prim["attributes"].items())),
                   json.dumps(prim.get("targets") or [], sort_keys=True))
            if key in first:                    # the same vertices as an earlier primitive, other triangles
                owner = parts[first[key]]
                part = replace(owner, name=name, faces=_faces(doc, prim, name, len(owner.positions)),
                               shares=first[key])
                textures.material(part, prim.get("material"))
                parts.append(part)
                continue
            part = _part(doc, prim, name, m, textures)
            if skin is not None:
                _attach_skin(doc, part, prim, g["skins"][int(skin)], joint_of)
            else:
                part.rigid_joint, part.rigid_offset = rigid, offset
            first[key] = len(parts)
            parts.append(part)
    if not parts:
        raise CharacterError(f"{src}: the file has no triangle mesh to draw")
    return CharacterMesh(parts, textures.notes)


def _part(doc: GltfDocument, prim: dict, name: str, mesh: int, textures: "_Textures") -> MeshPart:
    at = prim["attributes"]
    pos = accessor(doc, at["POSITION"]).astype(np.float64)
    V = len(pos)
    part = MeshPart(name, mesh, pos, accessor(doc, at["NORMAL"]).astype(np.float64) if "NORMAL" in at else None,
                    _faces(doc, prim, name, V))
    if "TEXCOORD_0" in at:
        part.uv = accessor(doc, at["TEXCOORD_0"]).astype(np.float32)
    targets = prim.get("targets") or []
    if targets:
        part.targets = np.stack([accessor(doc, t["POSITION"]).astype(np.float64) if "POSITION" in t
                                 else np.zeros((V, 3)) for t in targets])
        if part.normals is not None and any("NORMAL" in t for t in targets):
            part.target_normals = np.stack([accessor(doc, t["NORMAL"]).astype(np.float64) if "NORMAL" in t
                                            else np.zeros((V, 3)) for t in targets])
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


class _Textures:
    """Materials' base colour factors and decoded base colour textures (each image decoded once)."""

    def __init__(self, doc: GltfDocument):
        self.doc, self.notes = doc, []
        self._images: dict[int, np.ndarray | None] = {}
        g = doc.gltf
        props = ((g.get("extensions") or {}).get("VRM") or {}).get("materialProperties") or []
        self._mtoon = {str(p.get("name")): p for p in props if isinstance(p, dict)}

    def material(self, part: MeshPart, index: int | None) -> None:
        g = self.doc.gltf
        part.color, part.texture, part.alpha_mode, part.double_sided = (1.0, 1.0, 1.0, 1.0), None, "OPAQUE", False
        if index is None:                       # glTF's default material
            return
        try:
            mat = g["materials"][int(index)]
        except (KeyError, IndexError, TypeError, ValueError):
            raise CharacterError(f"{self.doc.source}: mesh {part.name} names a material that does not exist") \
                from None
        pbr = mat.get("pbrMetallicRoughness") or {}
        color = [float(c) for c in pbr.get("baseColorFactor", [1.0, 1.0, 1.0, 1.0])]
        tex = (pbr.get("baseColorTexture") or {}).get("index")
        mtoon = self._mtoon.get(str(mat.get("name")))
        if tex is None and mtoon is not None:
            tex = (mtoon.get("textureProperties") or {}).get("_MainTex")
            if "_Color" in (mtoon.get("vectorProperties") or {}):
                color = [float(c) for c in mtoon["vectorProperties"]["_Color"][:4]]
                color[:3] = [c ** 2.2 for c in color[:3]]                    # MToon's colour is sRGB
        part.color = tuple((color + [1.0] * 4)[:4])                         # type: ignore[assignment]
        part.alpha_mode = str(mat.get("alphaMode", "OPAQUE"))
        part.alpha_cutoff = float(mat.get("alphaCutoff", 0.5))
        part.double_sided = bool(mat.get("doubleSided", False))
        if tex is not None and part.uv is not None:
            part.texture, part.wrap = self._texture(int(tex), part.name)

    def _texture(self, index: int, name: str) -> tuple[np.ndarray | None, tuple[int, int]]:
        g = self.doc.gltf
        try:
            t = g["textures"][index]
            sampler = g.get("samplers", [])[int(t["sampler"])] if "sampler" in t else {}
            source = int(t["source"])
        except (KeyError, IndexError, TypeError, ValueError):
            self.notes.append(f"mesh {name}: texture {index} is damaged; drawn in its material's colour")
            return None, (10497, 10497)
        if source not in self._images:
            self._images[source] = self._decode(source)
        return self._images[source], (int(sampler.get("wrapS", 10497)), int(sampler.get("wrapT", 10497)))

    def _decode(self, source: int) -> np.ndarray | None:
        from PIL import Image

        g = self.doc.gltf
        try:
            im = g["images"][source]
            if "bufferView" in im:
                data = _view(self.doc, im["bufferView"], 0, np.dtype(np.uint8), 1,
                             int(g["bufferViews"][int(im["bufferView"])]["byteLength"]), f"image {source}").tobytes()
            elif str(im.get("uri", "")).startswith("data:"):
                data = base64.b64decode(im["uri"].split(",", 1)[1])
            else:
                self.notes.append(f"image {source} is a separate file; drawn in its material's colour")
                return None
            with Image.open(io.BytesIO(data)) as pic:
                pic = pic.convert("RGBA")
                if max(pic.size) > MAX_TEXELS:
                    pic.thumbnail((MAX_TEXELS, MAX_TEXELS))
                return np.asarray(pic, np.uint8).copy()
        except (CharacterError, KeyError, IndexError, TypeError, ValueError, OSError) as exc:
            self.notes.append(f"image {source} could not be decoded ({type(exc).__name__}); drawn in its "
                              "material's colour")
            return None
