"""Hostile character files (VRM / glTF / GLB / BVH) for tests/retarget/test_hostile_characters.py and
benchmarks/hostile_characters.py, one generator for both: a small valid VRM (`Base`: the mannequin's skeleton, a
skinned box per bone, two face presets and a texture), then one file per attack, each with what every entry point
must answer. The cases are declared without building anything; `write_characters` builds the files.

    cases = character_cases(original=Path("cryptovoxels.vrm"))     # [Crafted(name, what, refused, drawn, ...)]
    paths = write_characters(cases, folder)                          # {name: path}

Declaring imports neither gesturelsm nor torch (the benchmark's parent process stays small, so its children's
peak memory is their own); building does.

Big texture files are 1-bit PNGs of zeros (kilobytes on disk, hundreds of millions of texels decoded); accessors
without data ask for their zeros by a count alone.
"""
from __future__ import annotations

import base64
import copy
import json
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from _hostile_formats import (Base, append_view, blank_png, bvh_text, glb_bytes, jpeg_header, no_data,
                              unskinned_mesh)


@dataclass(frozen=True)
class Crafted:
    """A crafted character file and the answers it must get. `refused`: the one-line CharacterError (a regular
    expression) every entry point gives as the file is read; `drawn`: the refusal when its meshes are drawn or
    checked (render --rig, the page's upload), while `export --rig` takes it; `upload`: a refusal of the page
    alone; `note`: a note drawing gives (render --rig goes on); none of them: a usable file. `slow`: it costs
    seconds or tens of MB to build or draw (the tests leave it to the benchmark). `make(base)`: the file's bytes."""
    name: str
    what: str
    make: Callable[[Base], bytes | str] = field(repr=False, compare=False)
    refused: str | None = None
    drawn: str | None = None
    upload: str | None = None
    note: str | None = None
    slow: bool = False

    @property
    def page(self) -> bool:
        """Whether the page's Character upload takes this kind of file (.vrm / .glb / .gltf)."""
        return Path(self.name).suffix.lower() in (".vrm", ".glb", ".gltf")


def character_cases(original: Path | None = None, slow: bool = True) -> list[Crafted]:
    """The control and every crafted file, declared (nothing is built); `original`: a real character whose first half
    is one of them (cryptovoxels.vrm); slow=False leaves out the cases marked slow."""
    cases: list[Crafted] = [Crafted("valid.vrm", "a valid VRM 0.x (the control): 15 bones, skinned boxes, a face, "
                                    "a texture", lambda b: b.data)]

    def add(name: str, what: str, make: Callable[[Base], bytes | str], **expect) -> None:
        if slow or not expect.get("slow"):
            cases.append(Crafted(name, what, make, **expect))

    _container(add, original)
    _unbounded(add)
    _textures(add)
    _json(add)
    _hierarchy(add)
    _bvh(add)
    return cases


def write_characters(cases: list[Crafted], folder: Path) -> dict[str, Path]:
    """Each case's file written into `folder` (the control built once): {name: path}."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    base = Base.build(folder / "base.vrm")
    out = {}
    for case in cases:
        data = case.make(base)
        out[case.name] = folder / case.name
        out[case.name].write_bytes(data.encode() if isinstance(data, str) else data)
    return out


def _gltf_text(gltf: dict, blob: bytes) -> str:
    """A .gltf of `gltf` with `blob` as buffer 0's data: URI (byteLength as `gltf` states it)."""
    h = copy.deepcopy(gltf)
    h["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(blob).decode()
    return json.dumps(h, allow_nan=True)


def _container(add, original: Path | None) -> None:
    if original is not None and Path(original).is_file():
        name = Path(original).name
        add(f"truncated_{name}", f"the first half of {name}",
            lambda b: Path(original).read_bytes()[:Path(original).stat().st_size // 2],
            refused="truncated GLB file: its header says")
    add("truncated_half.vrm", "the control's first half", lambda b: b.data[:len(b.data) // 2],
        refused="truncated GLB file")
    add("header_length_long.glb", "the GLB header states 1 MB more than the file has",
        lambda b: glb_bytes(b.g, b.blob, total=len(b.data) + 2 ** 20), refused="header says")
    add("json_chunk_2GB.glb", "the JSON chunk's length states 2 GB",
        lambda b: glb_bytes(b.g, b.blob, json_length=2 ** 31), refused="JSON chunk says 2,147,483,648 bytes")
    add("bin_chunk_too_long.glb", "the binary chunk's length runs 4 KB past the file",
        lambda b: glb_bytes(b.g, b.blob, bin_length=len(b.blob) + 4096), refused="binary chunk says")
    add("bin_chunk_half.glb", "a GLB whose binary chunk holds half of buffer 0",
        lambda b: glb_bytes(b.g, b.blob[:len(b.blob) // 2]), refused="buffer 0 says .* bytes, the binary chunk holds")
    add("zeros.vrm", "100 zero bytes", lambda b: bytes(100), refused="not a glTF / VRM file")
    add("gltf_version_1.glb", "a GLB header of glTF version 1",
        lambda b: b.data[:4] + struct.pack("<I", 1) + b.data[8:], refused="only glTF 2.0")
    add("data_uri_half.gltf", "a .gltf whose data: URI holds half of buffer 0",
        lambda b: _gltf_text(b.g, b.blob[:len(b.blob) // 2]), refused="buffer 0 says .* bytes, its data: URI holds")


def _unbounded(add) -> None:
    def vertices(b: Base) -> int:
        return b.g["accessors"][b.accessor("POSITION")]["count"]

    def up_to_limit(b: Base, more: int) -> bytes:   # an extra mesh taking the drawn vertices to the limit (+ more)
        from gesturelsm.retarget.limits import MAX_VERTICES

        return b.mutated(lambda h: unskinned_mesh(h, no_data(h, MAX_VERTICES - vertices(b) + more)))

    def replace(attribute: str, **accessor) -> Callable[[Base], bytes]:
        return lambda b: b.mutated(lambda h: h["accessors"].__setitem__(b.accessor(attribute), accessor))

    def update(attribute: str, **fields) -> Callable[[Base], bytes]:
        return lambda b: b.mutated(lambda h: h["accessors"][b.accessor(attribute)].update(fields))

    add("vertices_1e8_no_data.vrm", "a mesh of 100,000,000 vertices without a buffer view (~20 KB)",
        replace("POSITION", componentType=5126, count=10 ** 8, type="VEC3"),
        refused="asks for 100,000,000 VEC3 elements")
    add("vertices_1e6_in_small_view.glb", "POSITION states 1,000,000 vertices in a view of a few KB",
        update("POSITION", count=10 ** 6), refused="needs .* bytes of buffer view")
    add("indices_2e9.glb", "an index accessor of 2,000,000,000 indices in a view of a few KB",
        update("indices", count=2 * 10 ** 9), refused="needs .* bytes of buffer view")
    add("indices_16M_no_data.glb", "16,000,000 indices without data (64 MB, an accessor's limit)",
        replace("indices", componentType=5125, count=16 * 10 ** 6, type="SCALAR"), drawn="5,333,333 triangles")
    add("vertices_at_limit.glb", "an extra mesh without data: 1,000,000 vertices in all (the limit)",
        lambda b: up_to_limit(b, 0), slow=True)
    add("vertices_over_limit.glb", "the same with one vertex more", lambda b: up_to_limit(b, 1),
        drawn="1,000,001 vertices")

    def instances(h: dict) -> None:
        for _ in range(5000):
            h["nodes"].append({"mesh": 0})
            h["scenes"][0]["nodes"].append(len(h["nodes"]) - 1)

    add("instances_5000.glb", "5,000 nodes drawing the body mesh", lambda b: b.mutated(instances),
        drawn="5,001 triangle primitives")

    def morphs(h: dict) -> None:
        p = no_data(h, 100_000)
        unskinned_mesh(h, p, [{"POSITION": p}] * 100)

    add("morph_targets_10M.glb", "100 morph targets of 100,000 vertices without data", lambda b: b.mutated(morphs),
        drawn="draws 10,000,[0-9]{3} morph-target values")
    add("joints_half_count.glb", "JOINTS_0 has half as many elements as POSITION",
        lambda b: b.mutated(lambda h: h["accessors"][b.accessor("JOINTS_0")].update(count=vertices(b) // 2)),
        drawn="JOINTS_0 is")
    add("position_vec2.glb", "POSITION declared VEC2", update("POSITION", type="VEC2"), drawn="POSITION is")

    def nan_vertex(b: Base) -> bytes:
        a = b.g["accessors"][b.accessor("POSITION")]
        off = b.g["bufferViews"][a["bufferView"]].get("byteOffset", 0) + a.get("byteOffset", 0)
        return glb_bytes(b.g, b.blob[:off] + struct.pack("<f", float("nan")) + b.blob[off + 4:])

    add("vertex_nan.glb", "a vertex at NaN in the binary data", nan_vertex, drawn="holds NaN")


def _texture(data: Callable[[], bytes]) -> Callable[[Base], bytes]:
    """The control with image 0 replaced by data()."""
    def make(b: Base) -> bytes:
        def change(h: dict) -> bytes:
            view, out = append_view(h, b.blob, data())
            h["images"][0]["bufferView"] = view
            return out
        return b.mutated(change)
    return make


def _textures(add) -> None:
    add("texture_12k.vrm", "a 12,000 x 12,000 PNG texture (18 KB)", _texture(lambda: blank_png(12000, 12000)),
        note="12,000 x 12,000 texels")
    add("texture_20k.vrm", "a 20,000 x 20,000 PNG texture (50 KB; Pillow's decompression bomb)",
        _texture(lambda: blank_png(20000, 20000)), note="20,000 x 20,000 texels")
    add("texture_jpeg_60k.vrm", "a JPEG header stating 60,000 x 60,000",
        _texture(lambda: jpeg_header(60000, 60000)), note="60,000 x 60,000 texels")
    add("texture_garbage.vrm", "an image of 4 KB of bytes that are no image", _texture(lambda: bytes(range(256)) * 16),
        note="could not be decoded")

    def many(b: Base) -> bytes:
        def change(h: dict) -> bytes:
            out, prim, png = b.blob, h["meshes"][0]["primitives"][0], blank_png(8192, 8192)
            for _ in range(8):
                view, out = append_view(h, out, png)
                h["images"].append({"bufferView": view, "mimeType": "image/png"})
                h["textures"].append({"source": len(h["images"]) - 1})
                h["materials"].append({"pbrMetallicRoughness": {"baseColorTexture": {"index": len(h["textures"]) - 1}}})
                h["meshes"][0]["primitives"].append(dict(prim, material=len(h["materials"]) - 1))
            return out
        return b.mutated(change)

    add("textures_8_of_8192.vrm", "8 more textures of 8,192 x 8,192, each at the limit (3 fit the total)", many,
        note="would take the decoded images over", slow=True)


def _node(i: int, **fields) -> Callable[[Base], bytes]:
    """The control with node i's fields updated."""
    return lambda b: b.mutated(lambda h: h["nodes"][i].update(fields))


def _json(add) -> None:
    def extras(raw: Callable[[], str]) -> Callable[[Base], bytes]:   # `raw` spliced in as top-level extras
        return lambda b: glb_bytes(None, b.blob, text=(json.dumps(b.g)[:-1] + ', "extras": ' + raw() + "}").encode())

    nan = float("nan")
    add("json_depth_100k.vrm", "JSON nested 100,000 deep", extras(lambda: "[" * 100_000 + "]" * 100_000),
        refused="nests deeper than 64 levels")
    add("json_depth_70.vrm", "JSON nested 70 deep (parses, but deeper than the limit)",
        extras(lambda: "[" * 70 + "]" * 70), refused="nests deeper than 64 levels")
    add("json_items_2M.vrm", "2,000,000 empty lists in the JSON (6 MB)",
        extras(lambda: "[" + ",".join(["[]"] * 2_000_000) + "]"), refused="over 1,000,000 items")
    add("node_as_string.vrm", "a node given as a string",
        lambda b: b.mutated(lambda h: h["nodes"].__setitem__(1, "LeftUpLeg")),
        refused="nodes entry 1 is a str, not an object")

    def matrix3(h: dict) -> None:
        for k in ("translation", "rotation", "scale"):
            h["nodes"][1].pop(k, None)
        h["nodes"][1]["matrix"] = [1, 0, 0]

    add("matrix_3_elements.vrm", "a node matrix of 3 numbers", lambda b: b.mutated(matrix3),
        refused="node 1's matrix is not 16 finite numbers")
    add("quaternion_text.vrm", "a rotation of [\"x\", 0, 0, 1]", _node(1, rotation=["x", 0, 0, 1]),
        refused="rotation is not 4 finite numbers")
    add("quaternion_zero.vrm", "a rotation of [0, 0, 0, 0]", _node(1, rotation=[0, 0, 0, 0]), refused="zero quaternion")
    add("skins_object.vrm", "`skins` an object instead of a list",
        lambda b: b.mutated(lambda h: h.update(skins=h["skins"][0])), refused="'skins' is a dict, not a list")
    for name, x in (("nan", nan), ("inf", float("inf")), ("1e300", 1e300)):
        add(f"translation_{name}.vrm", f"a node translation of {x}", _node(1, translation=[x, 0, 0]),
            refused="translation is not 3 finite numbers")

    def gltf_nan(b: Base) -> str:
        h = copy.deepcopy(b.g)
        h["nodes"][1]["translation"] = [nan, 0, 0]
        return _gltf_text(h, b.blob)

    add("translation_nan.gltf", "a .gltf (data: URI) with a node translation of NaN", gltf_nan,
        refused="translation is not 3 finite numbers")
    add("accessor_count_text.vrm", "an accessor count of \"lots\"",
        lambda b: b.mutated(lambda h: h["accessors"][0].update(count="lots")),
        refused="count \"lots\" is not a whole number")
    add("component_type_9999.vrm", "an accessor componentType of 9999",
        lambda b: b.mutated(lambda h: h["accessors"][0].update(componentType=9999)), refused="componentType 9999")
    add("humanoid_node_1e6.vrm", "a VRM humanoid bone on node 1,000,000",
        lambda b: b.mutated(lambda h: h["extensions"]["VRM"]["humanoid"]["humanBones"][0].update(node=10 ** 6)),
        refused="names no entry of 'nodes'")
    add("blendshape_weight_nan.vrm", "a VRM blend shape bind weight of NaN",
        lambda b: b.mutated(lambda h: h["extensions"]["VRM"]["blendShapeMaster"]["blendShapeGroups"][0]["binds"][0]
                            .update(weight=nan)), refused="weight NaN is not a finite number")
    add("nodes_100k.vrm", "100,000 empty nodes",
        lambda b: b.mutated(lambda h: h["nodes"].extend({} for _ in range(100_000))),
        refused="nodes; a character may have at most 65,536")


def _hierarchy(add) -> None:
    def parent(h: dict) -> int:                       # the first joint below the hips with children
        return next(i for i, n in enumerate(h["nodes"]) if i and n.get("children"))

    def deep(h: dict) -> None:
        head, start = next(i for i, n in enumerate(h["nodes"]) if n.get("name") == "Head"), len(h["nodes"])
        for k in range(300):
            h["nodes"].append({"name": f"hair{k}", "translation": [0, 0.001, 0],
                               **({"children": [start + k + 1]} if k < 299 else {})})
        h["nodes"][head].setdefault("children", []).append(start)
        h["skins"][0]["joints"] += list(range(start, start + 300))

    add("scale_zero_joint.vrm", "a joint scaled by 0", _node(2, scale=[0, 0, 0]),
        refused="zero scale; it cannot be posed")
    add("cycle.vrm", "the hips made a child of a joint below them",
        lambda b: b.mutated(lambda h: h["nodes"][parent(h)]["children"].append(0)), refused="has a cycle")
    add("own_child.vrm", "a node that is its own child", _node(3, children=[3]), refused="has a cycle")
    add("two_parents.vrm", "a joint with two parents",
        lambda b: b.mutated(lambda h: h["nodes"][0]["children"].append(h["nodes"][parent(h)]["children"][0])),
        refused="two parents")
    add("child_1e5.vrm", "a child index of 99,999",
        lambda b: b.mutated(lambda h: h["nodes"][0]["children"].append(99_999)),
        refused="children are not a list of node indices")
    add("joints_300_deep.vrm", "a chain of 300 joints under the head", lambda b: b.mutated(deep),
        refused="joints above it; at most 256")
    add("file_65MB.vrm", "the control padded to 65 MB", lambda b: glb_bytes(b.g, b.blob + bytes(65 * 2 ** 20)),
        refused="over the (64|32) MB limit", slow=True)
    add("file_40MB.vrm", "the control padded to 40 MB (over the page's 32 MB)",
        lambda b: glb_bytes(b.g, b.blob + bytes(40 * 2 ** 20)), upload="over the 32 MB limit", slow=True)


def _bvh(add) -> None:
    def offset_nan(b: Base) -> str:
        text = bvh_text(b.skel)
        first = text.index("OFFSET", text.index("JOINT"))
        return text[:first] + "OFFSET nan 0 0" + text[text.index("\n", first):]

    add("frames_1e11.bvh", "a BVH stating 99,999,999,999 frames with none there (only the hierarchy is read)",
        lambda b: bvh_text(b.skel, "Frames: 99999999999\nFrame Time: 0.0333333\n", ""), note="without a mesh")
    add("channels_1e9.bvh", "a BVH joint with 1,000,000,000 channels",
        lambda b: bvh_text(b.skel).replace("CHANNELS 3", "CHANNELS 1000000000", 1), refused="1,000,000,000 channels")
    add("offset_nan.bvh", "a BVH OFFSET of nan", offset_nan, refused="OFFSET is not three finite numbers")
    add("joints_20k.bvh", "a BVH hierarchy of 20,000 nested joints",
        lambda b: "HIERARCHY\nROOT Hips\n{\nOFFSET 0 0 0\n" + "JOINT j\n{\nOFFSET 0 1 0\n" * 20_000 + "}\n" * 20_001
        + "MOTION\n", refused="over 10,000 joints")
    add("hierarchy_5MB.bvh", "a BVH hierarchy of 5 MB of braces",
        lambda b: "HIERARCHY\nROOT Hips\n{\n" + "{ } " * (5 * 2 ** 18) + "}\nMOTION\n", refused="over 4 MB")
