"""What a glTF / VRM document must be before anything reads it: its JSON bounded (items, nesting), every part
this package reads of the type glTF says (a node is an object, a translation three finite numbers, `skins` a
list ...), every index naming something that exists, and its data where it says it is (buffer views inside
their buffer, accessors inside their view, an accessor without data no larger than MAX_ACCESSOR_BYTES).

    gltf = read_json(data, "avatar.vrm")        # dict, or CharacterError (damaged, too deep, too many items)
    check_document(gltf, blob, "avatar.vrm")   # CharacterError with one line naming the part and the problem

After `check_document` the rest of the package reads the JSON without guarding each access.
"""
from __future__ import annotations

import json
import math
from typing import Any

from .errors import CharacterError
from .limits import (MAX_ACCESSOR_BYTES, MAX_COORDINATE, MAX_JSON_DEPTH, MAX_JSON_ITEMS, MAX_NODES, count,
                     megabytes)

DTYPE_SIZE = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
LISTS = ("nodes", "meshes", "skins", "accessors", "bufferViews", "buffers", "materials", "textures", "images",
         "samplers", "scenes", "animations")


def read_json(data: bytes, source: str, what: str = "its JSON") -> Any:
    """The parsed JSON of `data`, refused before parsing when it has more than MAX_JSON_ITEMS items, and after
    when it nests deeper than MAX_JSON_DEPTH. json.JSONDecodeError / UnicodeDecodeError pass through."""
    items = data.count(b",") + data.count(b"[") + data.count(b"{")
    if items > MAX_JSON_ITEMS:
        raise CharacterError(f"{source}: {what} has over {count(MAX_JSON_ITEMS)} items ({count(items)}); "
                             "a character needs far fewer")
    try:
        value = json.loads(data)
    except RecursionError:
        raise CharacterError(f"{source}: {what} nests deeper than {MAX_JSON_DEPTH} levels") from None
    if _depth(value) > MAX_JSON_DEPTH:
        raise CharacterError(f"{source}: {what} nests deeper than {MAX_JSON_DEPTH} levels")
    return value


def _depth(value: Any) -> int:
    """Nesting depth of parsed JSON (a scalar 0, [] 1), without recursion."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        v, d = stack.pop()
        if isinstance(v, dict):
            v = list(v.values())
        elif not isinstance(v, list):
            continue
        deepest = max(deepest, d)
        if d <= MAX_JSON_DEPTH:
            stack += [(x, d + 1) for x in v if isinstance(x, (dict, list))]
    return deepest


def is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def is_number(v: Any) -> bool:
    """A finite JSON number no larger than MAX_COORDINATE (NaN, Infinity, 1e400 and 10**400 are not)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return False
    return abs(v) <= MAX_COORDINATE if is_int(v) else math.isfinite(v) and abs(v) <= MAX_COORDINATE


def _numbers(v: Any, n: int | None = None) -> bool:
    return isinstance(v, list) and (n is None or len(v) == n) and all(is_number(x) for x in v)


class _Checker:
    """One pass over a document; `fail` raises CharacterError('SOURCE: damaged glTF: WHAT')."""

    def __init__(self, gltf: dict, blob: bytes, source: str, glb: bool):
        self.g, self.blob, self.source, self.glb = gltf, blob, source, glb
        self.n = {}
        for key in LISTS:
            items = gltf.get(key, [])
            if not isinstance(items, list):
                self.fail(f"'{key}' is a {type(items).__name__}, not a list")
            for i, item in enumerate(items):
                if not isinstance(item, dict):
                    self.fail(f"{key} entry {i} is a {type(item).__name__}, not an object")
            self.n[key] = len(items)
        if self.n["nodes"] > MAX_NODES:
            raise CharacterError(f"{source}: {count(self.n['nodes'])} nodes; a character may have at most "
                                 f"{count(MAX_NODES)}")

    def fail(self, what: str) -> None:
        raise CharacterError(f"{self.source}: damaged glTF: {what}")

    def index(self, obj: dict, key: str, of: str, what: str, required: bool = False) -> None:
        """obj[key], when present (always when `required`), is an index into the list `of`."""
        if key not in obj and not required:
            return
        v = obj.get(key)
        if not is_int(v) or not 0 <= v < self.n[of]:
            self.fail(f"{what}'s {key} {_shown(v)} names no entry of '{of}' (it has {self.n[of]})")

    def natural(self, obj: dict, key: str, what: str, default: int = 0) -> int:
        v = obj.get(key, default)
        if not is_int(v) or v < 0:
            self.fail(f"{what}'s {key} {_shown(v)} is not a whole number >= 0")
        return v

    def buffers(self) -> list[int]:
        """Each buffer's usable length: its byteLength, checked against the data this file carries for it."""
        out = []
        for i, b in enumerate(self.g.get("buffers", [])):
            n = self.natural(b, "byteLength", f"buffer {i}", -1)
            uri = b.get("uri")
            if uri is not None and not isinstance(uri, str):
                self.fail(f"buffer {i}'s uri is not text")
            here = i == 0 and (uri is None and self.glb or isinstance(uri, str) and uri.startswith("data:"))
            if here and n > len(self.blob):
                what = "the binary chunk" if uri is None else "its data: URI"
                raise CharacterError(f"{self.source}: truncated or damaged file: buffer 0 says {count(n)} bytes, "
                                     f"{what} holds {count(len(self.blob))}")
            out.append(n)
        return out

    def views(self, buffers: list[int]) -> list[dict]:
        out = []
        for i, v in enumerate(self.g.get("bufferViews", [])):
            what = f"buffer view {i}"
            self.index(v, "buffer", "buffers", what, required=True)
            start, length = self.natural(v, "byteOffset", what), self.natural(v, "byteLength", what, -1)
            stride = v.get("byteStride")
            if stride is not None and (not is_int(stride) or not 1 <= stride <= 252):
                self.fail(f"{what}'s byteStride {_shown(stride)} is not from 1 to 252")
            if start + length > buffers[v["buffer"]]:
                raise CharacterError(f"{self.source}: truncated or damaged file: {what} reaches byte "
                                     f"{count(start + length)} of buffer {v['buffer']}, which has "
                                     f"{count(buffers[v['buffer']])}")
            out.append({"length": length, "stride": stride})
        return out

    def accessors(self, views: list[dict]) -> None:
        for i, a in enumerate(self.g.get("accessors", [])):
            what = f"accessor {i}"
            if a.get("componentType") not in DTYPE_SIZE or a.get("type") not in WIDTH:
                self.fail(f"{what} has componentType {_shown(a.get('componentType'))} and type "
                          f"{_shown(a.get('type'))}; glTF's are {sorted(DTYPE_SIZE)} and {', '.join(WIDTH)}")
            n = self.natural(a, "count", what, -1)
            elem = DTYPE_SIZE[a["componentType"]] * WIDTH[a["type"]]
            if "normalized" in a and not isinstance(a["normalized"], bool):
                self.fail(f"{what}'s normalized is not true or false")
            if "bufferView" in a:
                self.index(a, "bufferView", "bufferViews", what)
                self._inside(views[a["bufferView"]], self.natural(a, "byteOffset", what), n, elem,
                             f"{what} ({count(n)} {a['type']} elements)", a["bufferView"])
            elif n * elem > MAX_ACCESSOR_BYTES:
                raise CharacterError(f"{self.source}: {what} asks for {count(n)} {a['type']} elements "
                                     f"({megabytes(n * elem)}) without any data; at most "
                                     f"{megabytes(MAX_ACCESSOR_BYTES)} are read")
            if "sparse" in a:
                self._sparse(a, i, n, elem, views)

    def _inside(self, view: dict, offset: int, n: int, elem: int, what: str, vi: int) -> None:
        stride = view["stride"] or elem
        end = offset + (stride * (n - 1) + elem if n else 0)
        if end > view["length"]:
            raise CharacterError(f"{self.source}: truncated or damaged file: {what} needs {count(end)} bytes of "
                                 f"buffer view {vi}, which has {count(view['length'])}")

    def _sparse(self, a: dict, i: int, n: int, elem: int, views: list[dict]) -> None:
        what = f"accessor {i}'s sparse part"
        sp = a["sparse"]
        if not isinstance(sp, dict) or not isinstance(sp.get("indices"), dict) \
                or not isinstance(sp.get("values"), dict):
            self.fail(f"{what} is not an object with indices and values")
        k = self.natural(sp, "count", what, -1)
        if k > n:
            self.fail(f"{what} has {count(k)} entries for {count(n)} elements")
        idx, val = sp["indices"], sp["values"]
        if idx.get("componentType") not in (5121, 5123, 5125):
            self.fail(f"{what}'s indices are not unsigned integers")
        for part, size in ((idx, DTYPE_SIZE[idx["componentType"]]), (val, elem)):
            self.index(part, "bufferView", "bufferViews", what, required=True)
            view = dict(views[part["bufferView"]], stride=None)             # sparse data is tightly packed
            self._inside(view, self.natural(part, "byteOffset", what), k, size, what, part["bufferView"])


def _shown(v: Any) -> str:
    """A JSON value for messages, short: 'NaN', '"hips"', '[1, 2, 3]', 'dict'."""
    scalar = (str, int, float, bool, type(None))
    if isinstance(v, scalar):
        text = json.dumps(v)
    elif isinstance(v, list) and all(isinstance(x, scalar) for x in v[:17]):
        text = json.dumps(v[:17]) if len(v) <= 17 else json.dumps(v[:17])[:-1] + ", ...]"
    else:
        text = type(v).__name__
    return text if len(text) <= 40 else text[:37] + "..."

def _nodes(c: _Checker) -> None:
    nodes = c.g.get("nodes", [])
    for i, nd in enumerate(nodes):
        what = f"node {i}"
        kids = nd.get("children", [])
        if not isinstance(kids, list) or not all(is_int(k) and 0 <= k < len(nodes) for k in kids):
            c.fail(f"{what}'s children are not a list of node indices")
        if i in kids:
            raise CharacterError(f"{c.source}: the node hierarchy has a cycle (node {i} is its own child)")
        c.index(nd, "mesh", "meshes", what)
        c.index(nd, "skin", "skins", what)
        for key, n in (("translation", 3), ("rotation", 4), ("scale", 3), ("matrix", 16)):
            if key in nd and not _numbers(nd[key], n):
                c.fail(f"{what}'s {key} is not {n} finite numbers (got {_shown(nd[key])})")
        if "rotation" in nd and sum(x * x for x in nd["rotation"]) < 1e-12:
            c.fail(f"{what}'s rotation is the zero quaternion")
        if "matrix" in nd and min(sum(x * x for x in nd["matrix"][k:k + 3]) for k in (0, 4, 8)) < 1e-24:
            c.fail(f"{what}'s matrix has a zero scale")
        if "weights" in nd and not _numbers(nd["weights"]):
            c.fail(f"{what}'s morph weights are not finite numbers")


def _meshes(c: _Checker) -> None:
    for m, mesh in enumerate(c.g.get("meshes", [])):
        prims = mesh.get("primitives", [])
        if not isinstance(prims, list) or not all(isinstance(p, dict) for p in prims):
            c.fail(f"mesh {m}'s primitives are not a list of objects")
        if "weights" in mesh and not _numbers(mesh["weights"]):
            c.fail(f"mesh {m}'s morph weights are not finite numbers")
        for k, p in enumerate(prims):
            what = f"mesh {m} primitive {k}"
            targets = p.get("targets", [])
            if not isinstance(targets, list) or not all(isinstance(t, dict) for t in targets):
                c.fail(f"{what}'s morph targets are not a list of objects")
            for group in [p.get("attributes", {})] + targets:
                if not isinstance(group, dict):
                    c.fail(f"{what}'s attributes are not an object")
                for key in group:
                    c.index(group, key, "accessors", what)
            c.index(p, "indices", "accessors", what)
            c.index(p, "material", "materials", what)
            mode = p.get("mode", 4)
            if not is_int(mode) or not 0 <= mode <= 6:
                c.fail(f"{what}'s mode {_shown(mode)} is not a glTF primitive mode (0 to 6)")
    for s, skin in enumerate(c.g.get("skins", [])):
        joints = skin.get("joints")
        if not isinstance(joints, list) or not all(is_int(j) and 0 <= j < c.n["nodes"] for j in joints):
            c.fail(f"skin {s}'s joints are not a list of node indices")
        c.index(skin, "inverseBindMatrices", "accessors", f"skin {s}")
        c.index(skin, "skeleton", "nodes", f"skin {s}")


def _materials(c: _Checker) -> None:
    for i, mat in enumerate(c.g.get("materials", [])):
        what = f"material {i}"
        pbr = mat.get("pbrMetallicRoughness", {})
        if not isinstance(pbr, dict):
            c.fail(f"{what}'s pbrMetallicRoughness is not an object")
        if "baseColorFactor" in pbr and not _numbers(pbr["baseColorFactor"]):
            c.fail(f"{what}'s baseColorFactor is not finite numbers")
        tex = pbr.get("baseColorTexture")
        if tex is not None:
            if not isinstance(tex, dict):
                c.fail(f"{what}'s baseColorTexture is not an object")
            c.index(tex, "index", "textures", f"{what}'s baseColorTexture", required=True)
        if mat.get("alphaMode", "OPAQUE") not in ("OPAQUE", "MASK", "BLEND"):
            c.fail(f"{what}'s alphaMode {_shown(mat['alphaMode'])} is not OPAQUE, MASK or BLEND")
        if not is_number(mat.get("alphaCutoff", 0.5)) or not isinstance(mat.get("doubleSided", False), bool):
            c.fail(f"{what}'s alphaCutoff is not a number or its doubleSided not true or false")
    for i, t in enumerate(c.g.get("textures", [])):
        c.index(t, "source", "images", f"texture {i}")
        c.index(t, "sampler", "samplers", f"texture {i}")
    for i, im in enumerate(c.g.get("images", [])):
        c.index(im, "bufferView", "bufferViews", f"image {i}")
        if "uri" in im and not isinstance(im["uri"], str):
            c.fail(f"image {i}'s uri is not text")
    for i, s in enumerate(c.g.get("samplers", [])):
        if not all(is_int(s.get(k, 10497)) for k in ("wrapS", "wrapT")):
            c.fail(f"sampler {i}'s wrapS / wrapT are not whole numbers")


def _scenes_and_animations(c: _Checker) -> None:
    for i, sc in enumerate(c.g.get("scenes", [])):
        roots = sc.get("nodes", [])
        if not isinstance(roots, list) or not all(is_int(r) and 0 <= r < c.n["nodes"] for r in roots):
            c.fail(f"scene {i}'s nodes are not a list of node indices")
    if c.g.get("scene") is not None:
        c.index(c.g, "scene", "scenes", "the file")
    for a, anim in enumerate(c.g.get("animations", [])):
        samplers, channels = anim.get("samplers", []), anim.get("channels", [])
        if not isinstance(samplers, list) or not isinstance(channels, list) \
                or not all(isinstance(x, dict) for x in samplers + channels):
            c.fail(f"animation {a}'s samplers and channels are not lists of objects")
        for s in samplers:
            c.index(s, "input", "accessors", f"animation {a}'s sampler", required=True)
            c.index(s, "output", "accessors", f"animation {a}'s sampler", required=True)
        for ch in channels:
            target = ch.get("target")
            if not is_int(ch.get("sampler")) or not 0 <= ch["sampler"] < len(samplers) \
                    or not isinstance(target, dict):
                c.fail(f"animation {a} has a channel without a sampler of its own or a target")
            c.index(target, "node", "nodes", f"animation {a}'s channel target")


def _binds(c: _Checker, binds: Any, what: str, node: bool) -> None:
    """VRM morph-target binds: {node | mesh, index, weight} with whole numbers and a finite weight."""
    if not isinstance(binds, list) or not all(isinstance(b, dict) for b in binds):
        c.fail(f"{what}'s binds are not a list of objects")
    for b in binds:
        if node:
            c.index(b, "node", "nodes", what, required=True)
        elif not is_int(b.get("mesh")) or b["mesh"] < 0:
            c.fail(f"{what} binds mesh {_shown(b.get('mesh'))}, not a mesh index")
        c.natural(b, "index", what, -1)
        if not is_number(b.get("weight", 1.0)):
            c.fail(f"{what}'s weight {_shown(b.get('weight'))} is not a finite number")


def _dict(c: _Checker, parent: dict, key: str, what: str) -> dict:
    v = parent.get(key, {})
    if not isinstance(v, dict):
        c.fail(f"{what} is a {type(v).__name__}, not an object")
    return v


def _vrm(c: _Checker) -> None:
    ext = _dict(c, c.g, "extensions", "'extensions'")
    if "VRM" in ext:
        vrm = _dict(c, ext, "VRM", "the VRM extension")
        bones = _dict(c, vrm, "humanoid", "the VRM humanoid").get("humanBones", [])
        if not isinstance(bones, list) or not all(isinstance(b, dict) for b in bones):
            c.fail("the VRM humanoid's humanBones are not a list of objects")
        for b in bones:
            c.index(b, "node", "nodes", f"VRM humanoid bone {_shown(b.get('bone'))}")
        props = vrm.get("materialProperties", [])
        for p in props if isinstance(props, list) else []:
            if isinstance(p, dict):
                color = _dict(c, p, "vectorProperties", "a VRM material's vectorProperties").get("_Color", [])
                if not _numbers(color):
                    c.fail("a VRM material's _Color is not finite numbers")
                c.index(_dict(c, p, "textureProperties", "a VRM material's textureProperties"), "_MainTex",
                        "textures", "a VRM material")
        groups = _dict(c, vrm, "blendShapeMaster", "the VRM blendShapeMaster").get("blendShapeGroups", [])
        if not isinstance(groups, list) or not all(isinstance(g, dict) for g in groups):
            c.fail("the VRM blendShapeGroups are not a list of objects")
        for g in groups:
            _binds(c, g.get("binds", []), f"VRM blend shape {_shown(g.get('presetName'))}", node=False)
    if "VRMC_vrm" in ext:
        vrm = _dict(c, ext, "VRMC_vrm", "the VRMC_vrm extension")
        bones = _dict(c, _dict(c, vrm, "humanoid", "the VRM humanoid"), "humanBones", "the VRM humanBones")
        for name, b in bones.items():
            if not isinstance(b, dict):
                c.fail(f"VRM humanoid bone {_shown(name)} is not an object")
            c.index(b, "node", "nodes", f"VRM humanoid bone {_shown(name)}", required=True)
        presets = _dict(c, _dict(c, vrm, "expressions", "the VRM expressions"), "preset", "the VRM presets")
        for name, e in presets.items():
            if not isinstance(e, dict):
                c.fail(f"VRM expression {_shown(name)} is not an object")
            _binds(c, e.get("morphTargetBinds", []), f"VRM expression {_shown(name)}", node=True)


def check_document(gltf: Any, blob: bytes, source: str, glb: bool) -> None:
    """CharacterError unless `gltf` (parsed JSON) is a glTF document this package can read whole: see the module
    docstring. `blob`: buffer 0's bytes (the GLB's binary chunk or a .gltf's data: URI); `glb`: a GLB container."""
    if not isinstance(gltf, dict):
        raise CharacterError(f"{source}: damaged glTF: its JSON is a {type(gltf).__name__}, not an object")
    c = _Checker(gltf, blob, source, glb)
    c.accessors(c.views(c.buffers()))
    _nodes(c)
    _meshes(c)
    _materials(c)
    _scenes_and_animations(c)
    _vrm(c)
