"""A glTF accessor's numbers as a numpy array (byteStride, sparse values and normalised integers handled). The
document's structure is checked when it is read (`gltf_check`), so an accessor lies inside its buffer view and
one without data decodes to at most MAX_ACCESSOR_BYTES; the numbers themselves are checked here: a float
accessor holding NaN or an infinity is refused.

    positions = accessor(doc, prim["attributes"]["POSITION"])      # (count, 3) float32
"""
from __future__ import annotations

import numpy as np

from .errors import CharacterError
from .gltf import GltfDocument

DTYPES = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


def accessor(doc: GltfDocument, index: int) -> np.ndarray:
    """(count, width) array of a glTF accessor (byteStride, sparse and normalised integers handled)."""
    g, src = doc.gltf, doc.source
    try:
        a = g["accessors"][int(index)]
        dtype, n, count = np.dtype(DTYPES[a["componentType"]]), WIDTH[a["type"]], int(a["count"])
    except (KeyError, IndexError, TypeError, ValueError):
        raise CharacterError(f"{src}: accessor {index} is damaged or missing") from None
    out = view(doc, a.get("bufferView"), a.get("byteOffset", 0), dtype, n, count, f"accessor {index}") \
        if "bufferView" in a else np.zeros((count, n), dtype)
    sp = a.get("sparse")
    if sp:
        k = int(sp["count"])
        idx = view(doc, sp["indices"]["bufferView"], sp["indices"].get("byteOffset", 0),
                   np.dtype(DTYPES[sp["indices"]["componentType"]]), 1, k, f"accessor {index}")[:, 0]
        vals = view(doc, sp["values"]["bufferView"], sp["values"].get("byteOffset", 0), dtype, n, k,
                    f"accessor {index}")
        if idx.size and int(idx.max()) >= count:
            raise CharacterError(f"{src}: accessor {index}'s sparse indices exceed its count")
        out = out.copy()
        out[idx.astype(np.int64)] = vals
    if dtype.kind == "f" and not np.isfinite(out).all():
        raise CharacterError(f"{src}: accessor {index} holds NaN or infinite numbers")
    if a.get("normalized") and dtype.kind in "iu":
        top = float(np.iinfo(dtype).max)
        return np.maximum(out.astype(np.float32) / top, -1.0)
    return out


def view(doc: GltfDocument, index: int, offset: int, dtype: np.dtype, n: int, count: int, what: str) -> np.ndarray:
    """(count, n) elements of `dtype` from buffer view `index`, starting `offset` bytes into it (a copy)."""
    try:
        v = doc.gltf["bufferViews"][int(index)]
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
