"""Byte-level writers for the hostile character files (`_hostile_characters.py`): a GLB with any stated chunk
lengths, a 1-bit PNG of any size in kilobytes, a JPEG header of any size, a BVH of a skeleton, accessors without
data, and `Base`, the valid VRM every crafted glTF starts from.
"""
from __future__ import annotations

import copy
import json
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np


def glb_parts(data: bytes) -> tuple[dict, bytes]:
    """(JSON, binary chunk) of a well-formed GLB."""
    n = struct.unpack_from("<I", data, 12)[0]
    m = struct.unpack_from("<I", data, 20 + n)[0]
    return json.loads(data[20:20 + n]), data[28 + n:28 + n + m]


def glb_bytes(gltf: dict | None, blob: bytes, *, text: bytes | None = None, total: int | None = None,
              json_length: int | None = None, bin_length: int | None = None) -> bytes:
    """A GLB of `gltf` (or the JSON `text` as it is) and `blob`; total / json_length / bin_length: the header
    fields as stated (default: the truth)."""
    js = text if text is not None else json.dumps(gltf, allow_nan=True).encode()
    js += b" " * (-len(js) % 4)
    blob = blob + b"\0" * (-len(blob) % 4)
    body = struct.pack("<I4s", len(js) if json_length is None else json_length, b"JSON") + js
    body += struct.pack("<I4s", len(blob) if bin_length is None else bin_length, b"BIN\0") + blob
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body) if total is None else total) + body


def blank_png(width: int, height: int) -> bytes:
    """A 1-bit greyscale PNG of zeros: kilobytes on disk, width x height texels once decoded."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    row = bytes(1 + (width + 7) // 8)                      # filter byte + packed bits
    z, parts, left = zlib.compressobj(9), [], height
    while left:
        n = min(left, max(1, 2 ** 22 // len(row)))
        parts.append(z.compress(row * n))
        left -= n
    parts.append(z.flush())
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 1, 0, 0, 0, 0))
            + chunk(b"IDAT", b"".join(parts)) + chunk(b"IEND", b""))


def jpeg_header(width: int, height: int) -> bytes:
    """The start of a baseline JPEG stating width x height (no image data follows)."""
    sof = struct.pack(">BHHB", 8, height, width, 3) + b"\x01\x11\x00\x02\x11\x00\x03\x11\x00"
    return b"\xff\xd8\xff\xc0" + struct.pack(">H", len(sof) + 2) + sof + b"\xff\xd9"


def append_view(gltf: dict, blob: bytes, data: bytes) -> tuple[int, bytes]:
    """`data` added at the end of the buffer as a new buffer view: (its index, the new buffer)."""
    blob = blob + b"\0" * (-len(blob) % 4)
    gltf["bufferViews"].append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
    blob += data
    gltf["buffers"][0]["byteLength"] = len(blob)
    return len(gltf["bufferViews"]) - 1, blob


def no_data(gltf: dict, count: int, kind: str = "VEC3", ctype: int = 5126) -> int:
    """A new accessor of `count` elements without a buffer view (all zeros); its index."""
    gltf["accessors"].append({"componentType": ctype, "count": count, "type": kind})
    return len(gltf["accessors"]) - 1


def unskinned_mesh(gltf: dict, position: int, targets: list[dict] | None = None) -> None:
    """A mesh of accessor `position` on a node under the hips (drawn rigidly with it)."""
    prim = {"attributes": {"POSITION": position}, **({"targets": targets} if targets else {})}
    gltf["meshes"].append({"name": "extra", "primitives": [prim]})
    gltf["nodes"].append({"name": "extra", "mesh": len(gltf["meshes"]) - 1})
    gltf["nodes"][0].setdefault("children", []).append(len(gltf["nodes"]) - 1)


@dataclass
class Base:
    """The control every crafted glTF starts from: a VRM 0.x of the mannequin's skeleton (`skel`), a skinned box per
    bone, the `aa` and `blink` presets as morph targets and an 8 x 8 texture; its JSON `g` and binary chunk `blob`."""
    skel: Any
    g: dict
    blob: bytes

    @classmethod
    def build(cls, path: Path) -> "Base":
        from _rigs import build_rig, vrm_body_bones
        from _skinned import write_skinned_glb
        from gesturelsm.body.model import resolve_body

        skel, _ = build_rig(resolve_body(None).rest_joints(), fingers=False)
        texture = np.zeros((8, 8, 4), np.uint8)
        texture[..., 0], texture[..., 3] = np.arange(8)[:, None] * 32, 255
        write_skinned_glb(skel, path, vrm_body_bones(), vrm="0", presets=("aa", "blink"), texture=texture)
        return cls(skel, *glb_parts(path.read_bytes()))

    @property
    def data(self) -> bytes:
        return glb_bytes(self.g, self.blob)

    def mutated(self, change: Callable[[dict], bytes | None]) -> bytes:
        """The control's GLB after change(a copy of its JSON), which may return a new binary chunk."""
        h = copy.deepcopy(self.g)
        return glb_bytes(h, change(h) or self.blob)

    def accessor(self, attribute: str) -> int:
        """The accessor of the body mesh's `attribute` (or "indices")."""
        prim = self.g["meshes"][0]["primitives"][0]
        return prim[attribute] if attribute == "indices" else prim["attributes"][attribute]


def bvh_text(skel, frames: str = "Frames: 1\nFrame Time: 0.0333333\n", data: str | None = None) -> str:
    """A BVH of `skel` (joint names, OFFSETs = rest translations), its MOTION header `frames` and `data` (default:
    one frame of zeros)."""
    lines = ["HIERARCHY"]
    kids = {i: [c for c in range(len(skel)) if skel.parents[c] == i] for i in range(len(skel))}
    stack = [(i, 0, False) for i in range(len(skel)) if skel.parents[i] < 0]
    channels = 0
    while stack:
        i, depth, closing = stack.pop()
        tab = "\t" * depth
        if closing:
            lines.append(f"{tab}}}")
            continue
        t = skel.translation[i]
        chans = (["Xposition", "Yposition", "Zposition"] if skel.parents[i] < 0 else []) + \
            ["Zrotation", "Xrotation", "Yrotation"]
        channels += len(chans)
        lines += [f"{tab}{'ROOT' if skel.parents[i] < 0 else 'JOINT'} {skel.names[i]}", f"{tab}{{",
                  f"{tab}\tOFFSET {t[0]:.6f} {t[1]:.6f} {t[2]:.6f}", f"{tab}\tCHANNELS {len(chans)} {' '.join(chans)}"]
        stack.append((i, depth, True))
        stack += [(c, depth + 1, False) for c in reversed(kids[i])]
    data = " ".join(["0"] * channels) + "\n" if data is None else data
    return "\n".join(lines) + "\nMOTION\n" + frames + data
