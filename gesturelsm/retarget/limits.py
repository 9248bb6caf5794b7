"""How much of a character file is read, drawn and decoded: every count is checked from the file's own
numbers (its JSON, its GLB chunk headers, its image headers, its BVH words) before anything is allocated, so a
small hostile file cannot ask for gigabytes or minutes.

The figures are well above real humanoids: a VRoid avatar has 20-60 thousand vertices, under 100 primitives,
a few hundred nodes, a JSON chunk of well under a megabyte and textures of at most 4096 texels a side; a
Mixamo or BEAT BVH hierarchy is a few kilobytes. docs/CHARACTERS.md lists them for users.
"""
from __future__ import annotations

MAX_BYTES = 64 * 1024 * 1024          # a character file (the page takes 32 MB: webapp/character.py)

# glTF JSON (the JSON chunk of a GLB, or a whole .gltf)
MAX_JSON_ITEMS = 1_000_000            # values and separators ('{', '[', ','): bounds the parsed JSON's memory
MAX_JSON_DEPTH = 64                   # nesting of objects and lists (a glTF needs about 8)
MAX_NODES = 65_536
MAX_SKELETON_DEPTH = 256              # joints above a joint (a humanoid has about 15 to a finger tip)
MAX_ACCESSOR_BYTES = MAX_BYTES        # what an accessor without a buffer view (all zeros) may decode to
MAX_COORDINATE = 1e30                 # |x| of a node's translation, scale or matrix entry

# what is drawn (render --rig, batch --rig, the page's video)
MAX_PRIMITIVES = 4_096                # triangle primitives drawn, each mesh instance counted
MAX_VERTICES = 1_000_000              # vertices skinned per frame
MAX_TRIANGLES = 2_000_000
MAX_MORPH_VALUES = 8_000_000          # morph targets x vertices, over the drawn primitives
MAX_TEXELS_PER_IMAGE = 8192 * 8192    # an image's width x height, read from its header before decoding
MAX_TEXELS_TOTAL = 4 * MAX_TEXELS_PER_IMAGE    # every decoded image together

# BVH
MAX_BVH_HIERARCHY_BYTES = 4 * 1024 * 1024     # the text before MOTION
MAX_BVH_JOINTS = 10_000
MAX_BVH_CHANNELS = 6                  # per joint: 3 positions and 3 rotations


def count(n: int) -> str:
    """A count for messages: 100,000,000."""
    return f"{n:,}"


def megabytes(n: int) -> str:
    """A size for messages: '1.2 GB', '64 MB', '12 KB'."""
    if n >= 2 ** 30:
        return f"{n / 2 ** 30:.1f} GB"
    if n >= 2 ** 20:
        return f"{n / 2 ** 20:.0f} MB"
    return f"{max(n, 0) / 2 ** 10:.0f} KB"
