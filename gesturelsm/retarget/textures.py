"""Materials for drawing a character: base colour factors and base colour textures, each image decoded once.

An image's size is read from its PNG / JPEG header before it is decoded: one over MAX_TEXELS_PER_IMAGE texels,
or one that would take the decoded images together over MAX_TEXELS_TOTAL, is not decoded. Such an image, one
that cannot be decoded (damaged, a format other than PNG, JPEG or WebP, a decompression bomb Pillow refuses),
or one in a separate file leaves its material's colour factor and a note: drawing goes on without it. VRM 0.x
materials whose glTF entry has no texture take MToon's `_MainTex` / `_Color` from the VRM extension.

    textures = Textures(doc)
    textures.material(part, prim.get("material"))    # sets part.color, .texture, .wrap, .alpha_mode ...
    textures.notes                                    # what was drawn differently from the file
"""
from __future__ import annotations

import base64
import io
import struct
import warnings

import numpy as np
from PIL import Image

from .accessors import view
from .errors import CharacterError
from .gltf import GltfDocument
from .limits import MAX_TEXELS_PER_IMAGE, MAX_TEXELS_TOTAL, count

MAX_TEXELS = 1024                     # textures are shrunk to at most this many texels a side for drawing
FORMATS = ("PNG", "JPEG", "WEBP")     # glTF's image formats (WebP: EXT_texture_webp)
_JPEG_FRAMES = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}


def image_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) from a PNG's IHDR or a JPEG's frame header, without decoding; None for another format
    or a header that cannot be read."""
    if data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR" and len(data) >= 24:
        return struct.unpack(">II", data[16:24])
    if data[:2] != b"\xff\xd8":
        return None
    i = 2
    while i + 9 <= len(data):
        if data[i] != 0xFF:
            return None
        marker = data[i + 1]
        if marker == 0xFF:                                  # fill byte
            i += 1
            continue
        if marker == 0x01 or 0xD0 <= marker <= 0xD8:        # markers without a length
            i += 2
            continue
        if marker in _JPEG_FRAMES:
            h, w = struct.unpack(">HH", data[i + 5:i + 9])
            return w, h
        i += 2 + struct.unpack(">H", data[i + 2:i + 4])[0]
    return None


class Textures:
    """Materials' base colour factors and decoded base colour textures (each image decoded once)."""

    def __init__(self, doc: GltfDocument, decode: bool = True):
        self.doc, self.notes, self.decode = doc, [], decode       # decode=False: colours only, no image read
        self._images: dict[int, np.ndarray | None] = {}
        self._texels = 0                                    # decoded so far, against MAX_TEXELS_TOTAL
        g = doc.gltf
        props = ((g.get("extensions") or {}).get("VRM") or {}).get("materialProperties") or []
        self._mtoon = {str(p.get("name")): p for p in props if isinstance(p, dict)}

    def material(self, part, index: int | None) -> None:
        """Sets `part`'s (a mesh.MeshPart) colour, texture, wrap, alpha mode and sidedness from material `index`."""
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
                color[:3] = [max(c, 0.0) ** 2.2 for c in color[:3]]          # MToon's colour is sRGB
        part.color = tuple((color + [1.0] * 4)[:4])
        part.alpha_mode = str(mat.get("alphaMode", "OPAQUE"))
        part.alpha_cutoff = float(mat.get("alphaCutoff", 0.5))
        part.double_sided = bool(mat.get("doubleSided", False))
        if tex is not None and part.uv is not None and self.decode:
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

    def _bytes(self, source: int) -> bytes | None:
        g = self.doc.gltf
        im = g["images"][source]
        if "bufferView" in im:
            return view(self.doc, im["bufferView"], 0, np.dtype(np.uint8), 1,
                        int(g["bufferViews"][int(im["bufferView"])]["byteLength"]), f"image {source}").tobytes()
        if str(im.get("uri", "")).startswith("data:"):
            return base64.b64decode(im["uri"].split(",", 1)[1])
        self.notes.append(f"image {source} is a separate file; drawn in its material's colour")
        return None

    def _decode(self, source: int) -> np.ndarray | None:
        try:
            data = self._bytes(source)
            if data is None:
                return None
            size = image_size(data)
            if size is not None and not self._affordable(source, *size):
                return None
            with warnings.catch_warnings():
                warnings.simplefilter("error", Image.DecompressionBombWarning)
                with Image.open(io.BytesIO(data), formats=FORMATS) as pic:
                    if size is None and not self._affordable(source, *pic.size):
                        return None
                    pic = pic.convert("RGBA")
                    if max(pic.size) > MAX_TEXELS:
                        pic.thumbnail((MAX_TEXELS, MAX_TEXELS))
                    return np.asarray(pic, np.uint8).copy()
        except (CharacterError, KeyError, IndexError, TypeError, ValueError, OSError, EOFError,
                Image.DecompressionBombError, Image.DecompressionBombWarning) as exc:
            self.notes.append(f"image {source} could not be decoded ({type(exc).__name__}); drawn in its "
                              "material's colour")
            return None

    def _affordable(self, source: int, w: int, h: int) -> bool:
        """Whether a w x h image may be decoded (the limits in the module docstring); a note when not."""
        if w * h > MAX_TEXELS_PER_IMAGE:
            self.notes.append(f"image {source} is {count(w)} x {count(h)} texels, over the "
                              f"{count(MAX_TEXELS_PER_IMAGE)} an image may have; drawn in its material's colour")
            return False
        if self._texels + w * h > MAX_TEXELS_TOTAL:
            self.notes.append(f"image {source} would take the decoded images over {count(MAX_TEXELS_TOTAL)} "
                              "texels; drawn in its material's colour")
            return False
        self._texels += w * h
        return True
