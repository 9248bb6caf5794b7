"""A BVH file's HIERARCHY as a character skeleton: joints, OFFSETs (identity rest rotations), bone names
matched by a preset (Mixamo / BEAT v1 names, SMPL-X names) or a JSON map. The MOTION section is not read."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .errors import CharacterError
from .gltf import MAX_BYTES
from .names import guess_map, load_json_map, preset_map
from .skeleton import Skeleton


def parse_hierarchy(text: str, source: str) -> tuple[list[str], list[int], np.ndarray, list[list[str]]]:
    """(names, parents, offsets (N, 3), channels per joint) of a BVH HIERARCHY section; End Sites skipped."""
    tokens = text.split("MOTION", 1)[0].split()
    if not tokens or tokens[0] != "HIERARCHY":
        raise CharacterError(f"{source}: not a BVH file (it does not start with HIERARCHY)")
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[list[str]] = []
    stack: list[int] = []                   # joint index per open brace (-2 for an End Site)
    pending: int | None = None
    k = 1
    try:
        while k < len(tokens):
            tok = tokens[k]
            if tok in ("ROOT", "JOINT"):
                names.append(tokens[k + 1])
                parents.append(next((s for s in reversed(stack) if s >= 0), -1) if tok == "JOINT" else -1)
                offsets.append([0.0, 0.0, 0.0])
                channels.append([])
                pending = len(names) - 1
                k += 2
            elif tok == "End":
                pending = -2
                k += 2
            elif tok == "{":
                stack.append(pending if pending is not None else -2)
                pending = None
                k += 1
            elif tok == "}":
                stack.pop()
                k += 1
            elif tok == "OFFSET":
                if stack and stack[-1] >= 0:
                    offsets[stack[-1]] = [float(x) for x in tokens[k + 1:k + 4]]
                k += 4
            elif tok == "CHANNELS":
                n = int(tokens[k + 1])
                if stack and stack[-1] >= 0:
                    channels[stack[-1]] = tokens[k + 2:k + 2 + n]
                k += 2 + n
            else:
                raise CharacterError(f"{source}: unexpected word {tok!r} in the BVH hierarchy")
    except (IndexError, ValueError):
        raise CharacterError(f"{source}: damaged BVH hierarchy") from None
    if not names:
        raise CharacterError(f"{source}: the BVH hierarchy has no joints")
    return names, parents, np.asarray(offsets, np.float64), channels


def read_bvh_skeleton(path: str | Path, bone_map=None, limit: int = MAX_BYTES) -> Skeleton:
    path = Path(path)
    if not path.is_file():
        raise CharacterError(f"character file not found: {path}")
    if path.stat().st_size > limit:
        raise CharacterError(f"{path.name}: over the {limit / 2**20:.0f} MB limit for a character file")
    try:
        text = path.read_text()
    except UnicodeDecodeError:
        raise CharacterError(f"{path.name}: not a BVH file (not text)") from None
    names, parents, offsets, _ = parse_hierarchy(text, path.name)
    if isinstance(bone_map, dict):
        mapping = bone_map
    elif bone_map in ("mixamo", "smplx"):
        mapping = preset_map(bone_map, names)
    elif bone_map is not None:
        mapping = load_json_map(bone_map)
    else:
        mapping = guess_map(names)
    idx = {n: i for i, n in enumerate(names)}
    N = len(names)
    return Skeleton(names=names, parents=np.asarray(parents), translation=offsets,
                    rotation=np.tile(np.eye(3), (N, 1, 1)), scale=np.ones((N, 3)),
                    bones={j: idx[b] for j, b in mapping.items() if b in idx}, source=path.name, kind="bvh")
