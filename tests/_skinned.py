"""Skinned characters the tests build themselves: `build_rig`'s skeleton with a mesh of boxes, one along each
bone (from a joint to its first child), every box vertex fully weighted to its joint; optional VRM preset
expressions as morph targets on the head box, a base colour factor and a base colour texture.
"""
from __future__ import annotations

import json
import struct

import numpy as np

from _rigs import write_gltf

BOX_FACES = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4], [1, 2, 6], [1, 6, 5],
                      [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]])


def _box(a: np.ndarray, b: np.ndarray, half: float) -> np.ndarray:
    """(8, 3) corners of a box of half-width `half` around the segment a -> b."""
    d = b - a
    n = np.linalg.norm(d)
    d = d / n if n > 1e-9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(d, [0.0, 0.0, 1.0] if abs(d[2]) < 0.9 else [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    w = np.cross(d, u)
    ring = [half * (su * u + sw * w) for su, sw in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    return np.array([a + r for r in ring] + [b + r for r in ring])


def box_mesh(skel, half: float = 0.03) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """positions (V, 3), faces (F, 3), joint of each vertex (V,): one box per joint, along its first bone (a
    leaf joint: a box of 2 * half around it), in the skeleton's rest world."""
    W = skel.world()
    p = W[:, :3, 3]
    pos, faces, joint = [], [], []
    for i in range(len(skel)):
        kids = [c for c in range(len(skel)) if skel.parents[c] == i]
        a, b = (p[i], p[kids[0]]) if kids else (p[i] - [0, half, 0], p[i] + [0, 2 * half, 0])
        faces.append(BOX_FACES + len(pos))
        pos += list(_box(a, b, half))
        joint += [i] * 8
    return np.array(pos), np.concatenate(faces), np.array(joint)


def _pad(b: bytes) -> bytes:
    return b + b"\0" * (-len(b) % 4)


def write_skinned_glb(skel, path, humanoid: dict[str, str] | None = None, vrm: str = "1",
                      presets: tuple[str, ...] = (), color=(0.8, 0.2, 0.1, 1.0), texture: np.ndarray | None = None,
                      half: float = 0.03, badge: np.ndarray | None = None) -> dict:
    """A .glb / .vrm of the skeleton with a skinned box mesh (see `box_mesh`); `presets`: VRM expressions, each
    a morph target of the head box (target k moves its vertices 1 cm along -y, +x, +z... by k); `texture`:
    (H, W, 4) uint8 base colour texture (TEXCOORD_0 maps each box face to the whole image); `badge`: an (H, W, 4)
    image on an unskinned 30 cm square 25 cm in front of the chest joint (a child node of it, facing +z, the
    image's top row at its top edge, as glTF's v = 0). Returns the JSON."""
    g = write_gltf(skel, path, humanoid, vrm=vrm)
    pos, faces, joint = box_mesh(skel, half)
    V = len(pos)
    M = skel.world()
    ibm = np.linalg.inv(M).transpose(0, 2, 1).astype(np.float32)           # column-major
    chunks: list[tuple[bytes, int | None]] = []                               # (data, target)

    def add(arr: np.ndarray, ctype: int, kind: str, target: int | None = None, minmax: bool = False) -> int:
        data = np.ascontiguousarray(arr)
        view = {"buffer": 0, "byteOffset": sum(len(_pad(c)) for c, _ in chunks), "byteLength": data.nbytes}
        if target is not None:
            view["target"] = target
        chunks.append((data.tobytes(), target))
        g.setdefault("bufferViews", []).append(view)
        acc = {"bufferView": len(g["bufferViews"]) - 1, "componentType": ctype, "count": len(arr), "type": kind}
        if minmax:
            acc["min"], acc["max"] = arr.min(0).tolist(), arr.max(0).tolist()
        g.setdefault("accessors", []).append(acc)
        return len(g["accessors"]) - 1

    J = np.zeros((V, 4), np.uint16)
    J[:, 0] = joint
    Wt = np.zeros((V, 4), np.float32)
    Wt[:, 0] = 1.0
    attrs = {"POSITION": add(pos.astype(np.float32), 5126, "VEC3", 34962, True),
             "JOINTS_0": add(J, 5123, "VEC4", 34962), "WEIGHTS_0": add(Wt, 5126, "VEC4", 34962)}
    prim: dict = {"attributes": attrs, "indices": add(faces.reshape(-1).astype(np.uint32), 5125, "SCALAR", 34963),
                  "material": 0}
    material = {"pbrMetallicRoughness": {"baseColorFactor": list(color)}, "doubleSided": True}
    if texture is not None:
        uv = np.tile(np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0, 1], [1, 1], [1, 0], [0, 0]], np.float32),
                     (V // 8, 1))
        attrs["TEXCOORD_0"] = add(uv, 5126, "VEC2", 34962)
        import io

        from PIL import Image

        buf = io.BytesIO()
        Image.fromarray(texture).save(buf, format="PNG")
        png = buf.getvalue()
        chunks.append((png, None))
        g["bufferViews"].append({"buffer": 0, "byteOffset": sum(len(_pad(c)) for c, _ in chunks[:-1]),
                                 "byteLength": len(png)})
        g["images"] = [{"bufferView": len(g["bufferViews"]) - 1, "mimeType": "image/png"}]
        g["textures"] = [{"source": 0}]
        material["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    head = skel.bones["head"]
    if presets:
        targets = []
        for k, _ in enumerate(presets):
            d = np.zeros((V, 3), np.float32)
            d[joint == head, k % 3] = -0.01 * (k + 1)
            targets.append({"POSITION": add(d, 5126, "VEC3", 34962, True)})
        prim["targets"] = targets
    skin = {"joints": list(range(len(skel))), "inverseBindMatrices": add(ibm.reshape(-1, 16), 5126, "MAT4")}
    g["skins"] = [skin]
    g["materials"] = [material]
    g["meshes"] = [{"name": "boxes", "primitives": [prim], **({"weights": [0.0] * len(presets)} if presets else {})}]
    g["nodes"].append({"name": "body", "mesh": 0, "skin": 0})
    mesh_node = len(g["nodes"]) - 1
    g["scenes"][0]["nodes"].append(mesh_node)
    if presets and vrm == "1":
        g["extensions"]["VRMC_vrm"]["expressions"] = {"preset": {
            p: {"morphTargetBinds": [{"node": mesh_node, "index": k, "weight": 1.0}]} for k, p in enumerate(presets)}}
    elif presets:
        names = {"aa": "a", "ih": "i", "ou": "u", "ee": "e", "oh": "o"}
        g["extensions"]["VRM"]["blendShapeMaster"] = {"blendShapeGroups": [
            {"name": p, "presetName": names.get(p, p), "binds": [{"mesh": 0, "index": k, "weight": 100}]}
            for k, p in enumerate(presets)]}
    if badge is not None:
        import io

        from PIL import Image

        quad = np.array([[-0.15, 0.15, 0.25], [0.15, 0.15, 0.25], [0.15, -0.15, 0.25], [-0.15, -0.15, 0.25]],
                        np.float32)
        quv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)          # v = 0: the image's top row
        qa = {"POSITION": add(quad, 5126, "VEC3", 34962, True), "TEXCOORD_0": add(quv, 5126, "VEC2", 34962)}
        qi = add(np.array([0, 2, 1, 0, 3, 2], np.uint32), 5125, "SCALAR", 34963)
        buf = io.BytesIO()
        Image.fromarray(badge).save(buf, format="PNG")
        chunks.append((buf.getvalue(), None))
        g["bufferViews"].append({"buffer": 0, "byteOffset": sum(len(_pad(c)) for c, _ in chunks[:-1]),
                                 "byteLength": len(buf.getvalue())})
        g.setdefault("images", []).append({"bufferView": len(g["bufferViews"]) - 1, "mimeType": "image/png"})
        g.setdefault("textures", []).append({"source": len(g["images"]) - 1})
        g["materials"].append({"pbrMetallicRoughness": {"baseColorTexture": {"index": len(g["textures"]) - 1}},
                               "doubleSided": True})
        g["meshes"].append({"name": "badge", "primitives": [{"attributes": qa, "indices": qi,
                                                             "material": len(g["materials"]) - 1}]})
        g["nodes"].append({"name": "badge", "mesh": len(g["meshes"]) - 1})
        chest = skel.nodes[skel.bones["spine3"]]
        g["nodes"][chest].setdefault("children", []).append(len(g["nodes"]) - 1)
    blob = b"".join(_pad(c) for c, _ in chunks)
    g["buffers"] = [{"byteLength": len(blob)}]
    js = json.dumps(g).encode()
    js += b" " * (-len(js) % 4)
    with open(path, "wb") as fh:
        fh.write(struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(js) + 8 + len(blob)))
        fh.write(struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(blob), b"BIN\0") + blob)
    return g


def face_vrm(path, vrm: str = "0"):
    """A VRM (0.x or 1.0) on the mannequin's rest skeleton with every face preset the player drives (`aa ih ou ee oh`
    and `blink`), each a morph target of the head box. Returns the path."""
    from _rigs import build_rig, vrm_body_bones
    from gesturelsm.body.model import resolve_body
    from gesturelsm.retarget.face import PRESETS

    skel, _ = build_rig(resolve_body(None).rest_joints(), fingers=False)
    write_skinned_glb(skel, path, vrm_body_bones(), vrm=vrm, presets=PRESETS)
    return path
