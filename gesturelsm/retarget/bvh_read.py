"""A BVH file's HIERARCHY as a character skeleton: joints, OFFSETs (identity rest rotations), bone names
matched by a preset (Mixamo / BEAT v1 names, SMPL-X names) or a JSON map. The MOTION section is not read."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .errors import CharacterError
from .limits import MAX_BVH_CHANNELS, MAX_BVH_HIERARCHY_BYTES, MAX_BVH_JOINTS, MAX_BYTES, MAX_COORDINATE
from .names import guess_map, load_json_map, preset_map
from .skeleton import Skeleton


def _offset(words: list[str], source: str) -> list[float]:
    xyz = [float(x) for x in words]
    if len(xyz) != 3 or not all(math.isfinite(x) and abs(x) <= MAX_COORDINATE for x in xyz):
        raise CharacterError(f"{source}: a BVH OFFSET is not three finite numbers ({' '.join(words)[:40]})")
    return xyz


def parse_hierarchy(text: str, source: str) -> tuple[list[str], list[int], np.ndarray, list[list[str]]]:
    """(names, parents, offsets (N, 3), channels per joint) of a BVH HIERARCHY section; End Sites skipped."""
    head = text.split("MOTION", 1)[0]
    if len(head) > MAX_BVH_HIERARCHY_BYTES:
        raise CharacterError(f"{source}: the BVH hierarchy (the text before MOTION) is over "
                             f"{MAX_BVH_HIERARCHY_BYTES // 2 ** 20} MB; a skeleton needs a few KB")
    tokens = head.split()
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
                if len(names) == MAX_BVH_JOINTS:
                    raise CharacterError(f"{source}: the BVH hierarchy has over {MAX_BVH_JOINTS:,} joints")
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
                    offsets[stack[-1]] = _offset(tokens[k + 1:k + 4], source)
                k += 4
            elif tok == "CHANNELS":
                n = int(tokens[k + 1])
                if not 0 <= n <= MAX_BVH_CHANNELS:
                    raise CharacterError(f"{source}: a joint of the BVH hierarchy has {n:,} channels; a joint has "
                                         f"at most {MAX_BVH_CHANNELS}")
                if stack and stack[-1] >= 0:
                    channels[stack[-1]] = tokens[k + 2:k + 2 + n]
                k += 2 + n
            else:
                raise CharacterError(f"{source}: unexpected word {tok!r} in the BVH hierarchy")
    except CharacterError:
        raise
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
