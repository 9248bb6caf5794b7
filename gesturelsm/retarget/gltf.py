"""Characters from glTF 2.0 files: VRM 0.x / 1.0 (.vrm, binary glTF with a humanoid bone map), .glb and
.gltf with a skin (bones found by a name preset or a JSON map).

    doc = read_gltf("avatar.vrm")            # GltfDocument: JSON + binary chunk
    skel = gltf_skeleton(doc)                 # Skeleton with the humanoid bones mapped to SMPL-X joints
"""
from __future__ import annotations

import base64
import json
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import CharacterError
from .gltf_check import check_document, read_json
from .limits import MAX_BYTES
from .names import VRM0_THUMB, VRM1_THUMB, guess_map, load_json_map, preset_map, vrm_map
from .skeleton import Skeleton, quat_xyzw_to_matrix, topological

@dataclass
class GltfDocument:
    gltf: dict
    blob: bytes                        # the binary buffer (buffer 0), b"" when there is none
    source: str

    @property
    def vrm_version(self) -> str | None:
        ext = self.gltf.get("extensions") or {}
        if "VRMC_vrm" in ext:
            return "1"
        if "VRM" in ext:
            return "0"
        return None


def _check_size(path: Path, limit: int) -> None:
    if not path.is_file():
        raise CharacterError(f"character file not found: {path}")
    size = path.stat().st_size
    if size > limit:
        raise CharacterError(f"{path.name}: {size / 2**20:.1f} MB is over the {limit / 2**20:.0f} MB limit "
                             "for a character file")


def _glb_chunks(data: bytes, source: str) -> tuple[bytes, bytes]:
    """(JSON chunk, binary chunk or b"") of a GLB container; CharacterError when a length in its headers does
    not fit the file (a truncated or damaged file)."""
    if len(data) < 20:
        raise CharacterError(f"{source}: truncated GLB file ({len(data)} bytes)")
    _, version, total = struct.unpack_from("<4sII", data, 0)
    if version != 2:
        raise CharacterError(f"{source}: glTF version {version}; only glTF 2.0 is supported")
    if total > len(data):
        raise CharacterError(f"{source}: truncated GLB file: its header says {total:,} bytes, the file has "
                             f"{len(data):,}")
    n, kind = struct.unpack_from("<I4s", data, 12)
    if kind != b"JSON":
        raise CharacterError(f"{source}: damaged GLB file (its first chunk is not JSON)")
    if 20 + n > total:
        raise CharacterError(f"{source}: truncated or damaged GLB file: its JSON chunk says {n:,} bytes, the "
                             f"file has {total - 20:,} after the headers")
    off = 20 + n + (-n % 4)
    blob = b""
    if off + 8 <= total:
        m, kind = struct.unpack_from("<I4s", data, off)
        if kind == b"BIN\0":
            if off + 8 + m > total:
                raise CharacterError(f"{source}: truncated or damaged GLB file: its binary chunk says {m:,} "
                                     f"bytes, the file has {total - off - 8:,} after its header")
            blob = data[off + 8:off + 8 + m]
    return data[20:20 + n], blob


def parse_glb(data: bytes, source: str) -> GltfDocument:
    """A GLB container (or a .gltf JSON text with embedded data: buffers) -> GltfDocument, its structure checked
    (`gltf_check.check_document`): a truncated, damaged or oversized file raises CharacterError."""
    glb = data[:4] == b"glTF"
    if glb:
        text, blob = _glb_chunks(data, source)
        try:
            gltf = read_json(text, source, "its JSON chunk")
        except (UnicodeDecodeError, json.JSONDecodeError):
            raise CharacterError(f"{source}: damaged GLB file (its JSON chunk does not parse)") from None
    else:
        try:
            gltf = read_json(data, source)
        except (UnicodeDecodeError, json.JSONDecodeError):
            raise CharacterError(f"{source}: not a glTF / VRM file (neither a GLB container nor glTF JSON)") \
                from None
        if not isinstance(gltf, dict) or "asset" not in gltf:
            raise CharacterError(f"{source}: not a glTF / VRM file (JSON without a glTF 'asset')")
        blob = _embedded_buffer(gltf, source)
    check_document(gltf, blob, source, glb)
    return GltfDocument(gltf, blob, source)


def _embedded_buffer(gltf: dict, source: str) -> bytes:
    """Buffer 0 of a .gltf when it is a data: URI (a .gltf with external files is read for its skeleton only)."""
    bufs = gltf.get("buffers") or []
    uri = bufs[0].get("uri", "") if isinstance(bufs, list) and bufs and isinstance(bufs[0], dict) else ""
    if isinstance(uri, str) and uri.startswith("data:"):
        try:
            return base64.b64decode(uri.split(",", 1)[1])
        except (ValueError, IndexError):
            raise CharacterError(f"{source}: buffer 0 is a damaged data: URI") from None
    return b""


def read_gltf(path: str | Path, limit: int = MAX_BYTES) -> GltfDocument:
    path = Path(path)
    _check_size(path, limit)
    return parse_glb(path.read_bytes(), path.name)


def _humanoid(doc: GltfDocument) -> dict[str, int]:
    """VRM humanoid bone name -> node index (0.x list form or 1.0 dict form)."""
    ext = doc.gltf.get("extensions") or {}
    try:
        if "VRMC_vrm" in ext:
            bones = ext["VRMC_vrm"]["humanoid"]["humanBones"]
            return {name: int(b["node"]) for name, b in bones.items()}
        bones = ext["VRM"]["humanoid"]["humanBones"]
        return {b["bone"]: int(b["node"]) for b in bones if "bone" in b and "node" in b}
    except (KeyError, TypeError, ValueError):
        raise CharacterError(f"{doc.source}: damaged VRM humanoid bone map") from None


def node_trs(node: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A glTF node's local (translation, rotation matrix, scale); a `matrix` is decomposed."""
    if "matrix" in node:
        M = np.asarray(node["matrix"], np.float64).reshape(4, 4).T         # column-major in glTF
        t = M[:3, 3].copy()
        s = np.linalg.norm(M[:3, :3], axis=0)
        if np.any(s < 1e-12):
            raise CharacterError(f"a node matrix has a zero scale: {node.get('name', 'unnamed')}")
        return t, M[:3, :3] / s, s
    t = np.asarray(node.get("translation", [0, 0, 0]), np.float64)
    R = quat_xyzw_to_matrix(node.get("rotation", [0, 0, 0, 1]))
    s = np.asarray(node.get("scale", [1, 1, 1]), np.float64)
    return t, R, s


def gltf_skeleton(doc: GltfDocument, bone_map: str | dict[str, str] | None = None) -> Skeleton:
    """The character's joints (the skin's joints, the humanoid bones and all their ancestors, so `base` is the
    identity) with the humanoid bones mapped to SMPL-X joints.

    bone_map: None (VRM humanoid map, else the name preset that fits best), "mixamo" / "smplx", a JSON
    file path, or a dict {SMPL-X joint: node name}."""
    g, src = doc.gltf, doc.source
    nodes = g.get("nodes") or []
    if not g.get("skins"):
        raise CharacterError(f"{src}: the file has no skin (no skeleton to animate)")
    parents_of: dict[int, int] = {}
    for i, nd in enumerate(nodes):
        for c in nd.get("children", []) or []:
            if not isinstance(c, int) or not 0 <= c < len(nodes):
                raise CharacterError(f"{src}: node {i} lists a child {c!r} that does not exist")
            if c in parents_of and parents_of[c] != i:
                raise CharacterError(f"{src}: node {c} has two parents ({parents_of[c]} and {i})")
            parents_of[c] = i
    topological(parents_of, list(range(len(nodes))), src)          # a cycle anywhere in the hierarchy
    joints = sorted({int(j) for s in g["skins"] for j in s.get("joints", [])})
    if not joints or any(not 0 <= j < len(nodes) for j in joints):
        raise CharacterError(f"{src}: the skin's joint list is empty or names nodes that do not exist")
    human = _humanoid(doc) if doc.vrm_version else {}
    if any(not 0 <= n < len(nodes) for n in human.values()):
        raise CharacterError(f"{src}: the VRM humanoid map names nodes that do not exist")
    order = topological(parents_of, sorted(set(joints) | set(human.values())), src)   # + every ancestor
    pos = {n: i for i, n in enumerate(order)}
    names = [str(nodes[n].get("name", f"node{n}")) for n in order]
    trs = [node_trs(nodes[n]) for n in order]
    parents = [pos[parents_of[n]] if parents_of.get(n) in pos else -1 for n in order]
    name_to_idx = {}
    for i, nm in enumerate(names):
        name_to_idx.setdefault(nm, i)
    if isinstance(bone_map, dict):
        mapping = bone_map
    elif isinstance(bone_map, str) and bone_map in ("mixamo", "smplx"):
        mapping = preset_map(bone_map, names)
    elif isinstance(bone_map, (str, Path)):
        mapping = load_json_map(bone_map)
    elif human:
        by_node = {b: names[pos[n]] for b, n in human.items() if n in pos}
        mapping = vrm_map(by_node, VRM1_THUMB if doc.vrm_version == "1" else VRM0_THUMB)
    else:
        mapping = guess_map(names)
    bones = {j: name_to_idx[b] for j, b in mapping.items() if b in name_to_idx}
    return Skeleton(names=names, parents=np.asarray(parents), translation=np.stack([t for t, _, _ in trs]),
                    rotation=np.stack([R for _, R, _ in trs]), scale=np.stack([s for _, _, s in trs]),
                    bones=bones, nodes=order, source=src,
                    kind=f"vrm{doc.vrm_version}" if doc.vrm_version else "gltf")
