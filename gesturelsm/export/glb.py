"""Animated, skinned GLB (binary glTF 2.0) of a motion: mesh + 55-joint skeleton + one animation.

What Blender (File > Import > glTF 2.0), Unity (glTFast / UniGLTF), three.js / Babylon.js and Gradio's
`Model3D` open directly. trimesh can write GLB but not skins or animations, so this module writes glTF
itself with numpy + json:
* nodes 0..54: the SMPL-X joints (names as in `skeleton.py`), each with its rest translation from its
  parent (metres, y up, the body faces +z, as glTF wants); node 55 "body" holds the mesh and the skin;
  node 56 is the scene root with the armature (pelvis) and the mesh as children.
* mesh: the rest (T-pose) vertices for the motion's betas, smooth normals, JOINTS_0 / WEIGHTS_0 with the 4
  largest skinning weights per vertex renormalised to sum 1 (glTF's 4 influences; SMPL-X vertices rarely
  have more), and the first `max_expressions` expression directions as morph targets.
* skin: inverseBindMatrices = translation(-rest joint) (joint frames are world-aligned in the rest pose).
* animation "gesturelsm" at 30 fps, LINEAR: a rotation channel (unit quaternion x, y, z, w; sign-continuous)
  per joint (the pose plus the body model's pose mean, as the body model applies it), the pelvis
  translation (rest pelvis + trans) and, with morph targets, their weights (the expression coefficients).
Not representable in glTF: SMPL-X's pose-corrective blend shapes (posedirs), so a real SMPL-X body shows
plain linear blend skinning (the mannequin has none).
"""
from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import torch

from ..body.model import resolve_body
from ..errors import InputError
from ..motion.rotations import axis_angle_to_matrix
from ..motion.rotations import continuous_quaternions, matrix_to_quaternion_xyzw
from ..motion.sequence import MotionSequence
from ..motion.skeleton import NUM_JOINTS, PARENTS
from .guard import animation_times, check_motion, finite
from .skeleton import full_poses, joint_names, rest_pose

FLOAT, UBYTE, USHORT, UINT = 5126, 5121, 5123, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963



CHUNK = 4096                                # frames converted at once by the writers


def top_k_weights(W: np.ndarray, k: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """(V, J) skinning weights -> (V, k) joint indices and (V, k) weights (largest, renormalised)."""
    idx = np.argsort(-W, axis=1)[:, :k]
    w = np.take_along_axis(W, idx, 1).astype(np.float64)
    w = np.maximum(w, 0.0)
    s = w.sum(1, keepdims=True)
    w = np.where(s > 0, w / np.where(s > 0, s, 1.0), np.eye(k)[0])
    idx = np.where(w > 0, idx, 0)
    return idx.astype(np.uint8 if W.shape[1] < 256 else np.uint16), w.astype(np.float32)


class GltfBuffer:
    """A glTF binary buffer being written: its bytes, and the buffer views and accessors that describe them. `after`
    continues an existing file's (its own data first, so its indices stay valid)."""

    def __init__(self) -> None:
        self.blob = bytearray()
        self.views: list[dict] = []
        self.accessors: list[dict] = []

    @classmethod
    def after(cls, gltf: dict, blob: bytes) -> "GltfBuffer":
        """A buffer that starts with a file's own binary data, views and accessors (`gltf`'s lists, appended to)."""
        b = cls()
        b.blob = bytearray(blob)
        b.views = gltf.setdefault("bufferViews", [])
        b.accessors = gltf.setdefault("accessors", [])
        return b

    def add(self, data: np.ndarray, ctype: int, atype: str, target: int | None = None,
            minmax: bool = False, normalized: bool = False) -> int:
        data = np.ascontiguousarray(data)
        if ctype == FLOAT:
            finite(data, "the animation's values")                  # a NaN in a GLB plays as a broken model
        while len(self.blob) % 4:
            self.blob.append(0)
        view = {"buffer": 0, "byteOffset": len(self.blob), "byteLength": data.nbytes}
        if target is not None:
            view["target"] = target
        self.blob += data.tobytes()
        self.views.append(view)
        ncomp = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}[atype]
        acc = {"bufferView": len(self.views) - 1, "componentType": ctype, "count": int(data.size // ncomp),
               "type": atype}
        if normalized:
            acc["normalized"] = True
        if minmax:
            flat = data.reshape(-1, ncomp)
            acc["min"] = [float(x) for x in flat.min(0)]
            acc["max"] = [float(x) for x in flat.max(0)]
        self.accessors.append(acc)
        return len(self.accessors) - 1


def _vertex_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    n = np.zeros_like(v)
    for k in range(3):
        np.add.at(n, f[:, k], fn)
    n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-12
    return n


def _add_mesh(b: GltfBuffer, V: np.ndarray, F: np.ndarray, W: np.ndarray) -> dict:
    """The rest mesh's buffers: (V, 3) vertices, (F, 3) faces, (V, 55) skinning weights -> a glTF primitive."""
    jidx, jw = top_k_weights(W, 4)
    a_pos = b.add(V, FLOAT, "VEC3", ARRAY_BUFFER, minmax=True)
    a_nrm = b.add(_vertex_normals(V.astype(np.float64), F.astype(np.int64)).astype(np.float32), FLOAT, "VEC3",
                  ARRAY_BUFFER)
    a_jnt = b.add(jidx, UBYTE if jidx.dtype == np.uint8 else USHORT, "VEC4", ARRAY_BUFFER)
    a_wgt = b.add(jw, FLOAT, "VEC4", ARRAY_BUFFER)
    a_idx = b.add(F.reshape(-1).astype(np.uint16 if len(V) < 65536 else np.uint32),
                  USHORT if len(V) < 65536 else UINT, "SCALAR", ELEMENT_ARRAY_BUFFER)
    return {"attributes": {"POSITION": a_pos, "NORMAL": a_nrm, "JOINTS_0": a_jnt, "WEIGHTS_0": a_wgt},
            "indices": a_idx, "material": 0, "mode": 4}


def _add_morph_targets(b: GltfBuffer, body, seq: MotionSequence, num_vertices: int,
                       max_expressions: int) -> tuple[list[int], list[dict]]:
    """Expression directions the body actually uses (of the first max_expressions): (their indices, targets)."""
    E = min(int(body.num_expressions), int(max_expressions), seq.expressions.shape[1])
    dirs = body.module.expr_dirs.detach().cpu().numpy()[..., :E] if E > 0 else np.zeros((num_vertices, 3, 0))
    used = [e for e in range(E) if np.abs(dirs[..., e]).max() > 0]
    targets = [{"POSITION": b.add(np.ascontiguousarray(dirs[..., e]).astype(np.float32), FLOAT, "VEC3",
                                  ARRAY_BUFFER, minmax=True)} for e in used]
    return used, targets


def _add_animation(b: GltfBuffer, seq: MotionSequence, body, J: np.ndarray,
                   used: list[int]) -> tuple[list[dict], list[dict]]:
    """Samplers and channels at seq.fps: a rotation per joint, the pelvis translation (rest pelvis J[0] + trans)
    and the used expressions' morph weights."""
    T = seq.num_frames
    times = animation_times(T, seq.fps)
    a_time = b.add(times, FLOAT, "SCALAR", minmax=True)
    quats = np.empty((T, NUM_JOINTS, 4), np.float32)
    for a in range(0, T, CHUNK):               # in chunks of frames: an hour of motion in bounded memory
        R = axis_angle_to_matrix(torch.from_numpy(full_poses(seq.slice(a, a + CHUNK), body).reshape(
            -1, NUM_JOINTS, 3))).numpy()
        quats[a:a + CHUNK] = matrix_to_quaternion_xyzw(R)
    quats = continuous_quaternions(quats)                                            # (T, 55, 4)
    samplers, channels = [], []
    for j in range(NUM_JOINTS):
        samplers.append({"input": a_time, "output": b.add(np.ascontiguousarray(quats[:, j]), FLOAT, "VEC4"),
                         "interpolation": "LINEAR"})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": j, "path": "rotation"}})
    root = (seq.trans.astype(np.float64) + J[0]).astype(np.float32)
    samplers.append({"input": a_time, "output": b.add(root, FLOAT, "VEC3"), "interpolation": "LINEAR"})
    channels.append({"sampler": len(samplers) - 1, "target": {"node": 0, "path": "translation"}})
    if used:
        wts = seq.expressions[:, used].astype(np.float32)                              # (T, E') row-major
        samplers.append({"input": a_time, "output": b.add(wts.reshape(-1), FLOAT, "SCALAR"),
                         "interpolation": "LINEAR"})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": NUM_JOINTS, "path": "weights"}})
    return samplers, channels


def _nodes(J: np.ndarray, label: list[str]) -> list[dict]:
    """The 55 joint nodes (rest translation from the parent), then the body mesh node and the scene root."""
    nodes = []
    for j in range(NUM_JOINTS):
        t = J[j] if j == 0 else J[j] - J[PARENTS[j]]
        node = {"name": label[j], "translation": [float(x) for x in t]}
        kids = [c for c in range(NUM_JOINTS) if PARENTS[c] == j]
        if kids:
            node["children"] = kids
        nodes.append(node)
    nodes.append({"name": "body", "mesh": 0, "skin": 0})
    nodes.append({"name": "gesturelsm", "children": [0, NUM_JOINTS]})
    return nodes


def write_glb(path: Path, gltf: dict, blob: bytearray) -> None:
    """The GLB container: 12-byte header, then the JSON and BIN chunks, each padded to 4 bytes."""
    js = json.dumps(gltf, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    data = bytes(blob) + b"\0" * (-len(blob) % 4)
    total = 12 + 8 + len(js) + 8 + len(data)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as fh:
        fh.write(struct.pack("<4sII", b"glTF", 2, total))
        fh.write(struct.pack("<I4s", len(js), b"JSON") + js)
        fh.write(struct.pack("<I4s", len(data), b"BIN\0") + data)


def export_glb(seq: MotionSequence, path: str | Path, body=None, names: str = "animator",
               max_expressions: int = 10, color: tuple[float, float, float] = (0.78, 0.69, 0.60)) -> Path:
    """Write `seq` as an animated skinned GLB (see the module docstring); returns the path."""
    check_motion(seq)
    label = joint_names(names)
    body = resolve_body(body)
    path = Path(path)
    J = body.rest_joints(seq.betas).astype(np.float64)                               # (55, 3)
    rest = rest_pose(body, seq.betas)                                                 # bind pose
    V = rest.vertices[0].astype(np.float32)                                           # (V, 3)
    F = body.faces.astype(np.uint32)
    W = body.module.lbs_weights.detach().cpu().numpy()                                # (V, 55)

    b = GltfBuffer()
    prim = _add_mesh(b, V, F, W)
    used, targets = _add_morph_targets(b, body, seq, len(V), max_expressions)
    ibm = np.tile(np.eye(4), (NUM_JOINTS, 1, 1))
    ibm[:, :3, 3] = -J
    a_ibm = b.add(np.transpose(ibm, (0, 2, 1)).astype(np.float32), FLOAT, "MAT4")    # column-major
    samplers, channels = _add_animation(b, seq, body, J, used)

    mesh = {"name": "body", "primitives": [prim]}
    if targets:
        prim["targets"] = targets
        mesh["weights"] = [0.0] * len(targets)
        mesh["extras"] = {"targetNames": [f"expression{e:03d}" for e in used]}
    gltf = {
        "asset": {"version": "2.0", "generator": "gesturelsm export_glb"},
        "scene": 0,
        "scenes": [{"name": "gesturelsm", "nodes": [NUM_JOINTS + 1]}],
        "nodes": _nodes(J, label),
        "meshes": [mesh],
        "materials": [{"name": "clay", "pbrMetallicRoughness": {
            "baseColorFactor": [float(c) ** 2.2 for c in color] + [1.0], "metallicFactor": 0.0,
            "roughnessFactor": 0.6}, "doubleSided": False}],
        "skins": [{"name": "smplx", "inverseBindMatrices": a_ibm, "joints": list(range(NUM_JOINTS)),
                   "skeleton": 0}],
        "animations": [{"name": "gesturelsm", "samplers": samplers, "channels": channels}],
        "accessors": b.accessors,
        "bufferViews": b.views,
        "buffers": [{"byteLength": len(b.blob)}],
        "extras": {"fps": seq.fps, "frames": seq.num_frames, "units": "metres, y up, body faces +z"},
    }
    write_glb(path, gltf, b.blob)
    return path


def read_glb(path: str | Path) -> tuple[dict, bytes]:
    """(glTF JSON, binary chunk) of a GLB file (for checks and tests)."""
    data = Path(path).read_bytes()
    magic, version, total = struct.unpack_from("<4sII", data, 0)
    if magic != b"glTF" or version != 2 or total != len(data):
        raise InputError(f"{path}: not a GLB 2.0 file")
    n, kind = struct.unpack_from("<I4s", data, 12)
    if kind != b"JSON":
        raise InputError(f"{path}: first chunk is not JSON")
    gltf = json.loads(data[20:20 + n])
    off = 20 + n
    blob = b""
    if off < len(data):
        m, kind = struct.unpack_from("<I4s", data, off)
        blob = data[off + 8:off + 8 + m]
    return gltf, blob


def accessor_array(gltf: dict, blob: bytes, index: int) -> np.ndarray:
    """The data of accessor `index` as a numpy array (count, components)."""
    acc = gltf["accessors"][index]
    view = gltf["bufferViews"][acc["bufferView"]]
    dtype = {FLOAT: np.float32, UBYTE: np.uint8, USHORT: np.uint16, UINT: np.uint32}[acc["componentType"]]
    ncomp = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}[acc["type"]]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    arr = np.frombuffer(blob, dtype, acc["count"] * ncomp, start)
    return arr.reshape(acc["count"], ncomp)
