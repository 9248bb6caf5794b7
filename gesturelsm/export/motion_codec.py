"""The one binary motion format of the in-browser player: the offline player's motion files (`.bin`, one per
method, export/player_payload.py) and the live feed's WebSocket messages (gesturelsm/webapp/live.py `payload`) are
both one record. This module writes and reads it; the page decodes it in gesturelsm/webapp/player/src/motion_decoder.js.

A record, little-endian throughout:

    header (28 bytes)
      0  magic        4 bytes  b"GLSM"
      4  version      uint16   1
      6  kind         uint16   1 = quaternion: rotations are each joint's local rotation x, y, z, w and root is the
                               pelvis position (what the player draws, export/player_payload.py `motion_arrays`);
                               2 = axis-angle: rotations are SMPL-X poses (3 per joint) and root is trans
      8  joints       uint16   J (55 for SMPL-X)
     10  expressions  uint16   E (weights per frame, often 0)
     12  fps          float32  frames per second (30)
     16  start        uint32   index of the first frame in its stream (0 for a whole motion)
     20  frames       uint32   T, frames in this record (0: a message with meta only)
     24  meta_bytes   uint32   length of the meta block
    data, float32
      rotations    (T, J, 4) or (T, J, 3)
      root         (T, 3)      metres
      expressions  (T, E)
    meta: meta_bytes of UTF-8 JSON, an object (the live feed's status and latency; empty in files)

Version 2 is version 1 with a character section: the same motion on the visitor's character (the live feed with a
character chosen, gesturelsm/live/characters.py). A record without one is written as version 1, byte for byte.

    header (28 bytes) as above, version 2
    section header (4 bytes)
     28  bones        uint16   B, the character's humanoid bones (its hips first)
     30  morphs       uint16   F, the character's face morph-target channels (0: none)
    data, float32: rotations, root, expressions as above, then
      bone rotations (T, B, 4)  each bone node's local rotation x, y, z, w (sign-continuous over the stream)
      bone root      (T, 3)     the hips node's local translation, the character's units
      morph weights  (T, F)     the face's morph-target weights, in the order of the channels the stream's first
                                message lists (meta.character.morphs, [[glTF mesh, target], ...])
    meta

In a version 2 record with F = 0 no morph weights follow the hips' translation.

The headers are a multiple of 4 bytes, so the page views the floats in place (no copy). 10 s of the player's
motion at 30 fps is 28 + 300 x (55 x 4 + 3 + E) x 4 bytes, ~0.27 MB per method.
"""
from __future__ import annotations

import json
import struct
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..motion.skeleton import NUM_JOINTS
from .guard import check_rate, finite

MAGIC = b"GLSM"
VERSION = 1                                     # a record without a character section
CHARACTER_VERSION = 2                           # a record with one
HEADER = struct.Struct("<4sHHHHfIII")
SECTION = struct.Struct("<HH")                  # version 2: bones, morph channels
QUATERNION, AXIS_ANGLE = "quaternion", "axis-angle"
KINDS = {QUATERNION: 1, AXIS_ANGLE: 2}          # kind -> its code in the header
CHANNELS = {QUATERNION: 4, AXIS_ANGLE: 3}       # numbers per joint and frame


class MotionFormatError(InputError):
    """Bytes that are not a motion record this reader understands; the message says what is wrong."""


def _empty(*shape: int) -> np.ndarray:
    return np.zeros(shape, np.float32)


@dataclass(frozen=True)
class MotionRecord:
    """Frames `start .. start + frames - 1` of a motion, with an optional meta object (JSON-serialisable)."""
    rotations: np.ndarray = field(default_factory=lambda: _empty(0, NUM_JOINTS, 4))   # (T, J, 4) or (T, J, 3)
    root: np.ndarray = field(default_factory=lambda: _empty(0, 3))                    # (T, 3)
    expressions: np.ndarray = field(default_factory=lambda: _empty(0, 0))             # (T, E)
    kind: str = QUATERNION
    fps: float = 30.0
    start: int = 0
    meta: dict = field(default_factory=dict)
    bone_rotations: np.ndarray | None = None    # (T, B, 4) the character section (version 2), None: none
    bone_root: np.ndarray | None = None         # (T, 3)
    morph: np.ndarray | None = None             # (T, F) the character's face morph weights, None: none (F = 0)

    @property
    def frames(self) -> int:
        return int(self.rotations.shape[0])


def encode(record: MotionRecord) -> bytes:
    """The record's bytes (layout in the module docstring)."""
    if record.kind not in KINDS:
        raise ValueError(f"unknown motion kind {record.kind!r} (use {' or '.join(KINDS)})")
    rot = np.asarray(record.rotations, "<f4")
    T = rot.shape[0]
    root = np.asarray(record.root, "<f4")
    expr = np.asarray(record.expressions, "<f4")
    if rot.ndim != 3 or rot.shape[2] != CHANNELS[record.kind]:
        raise ValueError(f"{record.kind} rotations must be (frames, joints, {CHANNELS[record.kind]}), got {rot.shape}")
    if root.shape != (T, 3) or expr.ndim != 2 or expr.shape[0] != T:
        raise ValueError(f"root must be ({T}, 3) and expressions ({T}, E), got {root.shape} and {expr.shape}")
    for what, values in (("rotations", rot), ("root", root), ("expressions", expr)):
        finite(values, f"the motion record's {what}")
    check_rate(record.fps, "the motion record")
    meta = json.dumps(record.meta, separators=(",", ":")).encode() if record.meta else b""
    section, bones = b"", []
    if record.bone_rotations is not None:
        brot, broot = np.asarray(record.bone_rotations, "<f4"), np.asarray(record.bone_root, "<f4")
        if brot.ndim != 3 or brot.shape[0] != T or brot.shape[2] != 4 or broot.shape != (T, 3):
            raise ValueError(f"bone rotations must be ({T}, bones, 4) and bone root ({T}, 3), got {brot.shape} and "
                             f"{broot.shape}")
        morph = np.zeros((T, 0), "<f4") if record.morph is None else np.asarray(record.morph, "<f4")
        if morph.ndim != 2 or morph.shape[0] != T:
            raise ValueError(f"morph weights must be ({T}, channels), got {morph.shape}")
        for what, values in (("bone rotations", brot), ("bone root", broot), ("morph weights", morph)):
            finite(values, f"the motion record's {what}")
        section, bones = SECTION.pack(brot.shape[1], morph.shape[1]), [brot.tobytes(), broot.tobytes(), morph.tobytes()]
    elif record.morph is not None:
        raise ValueError("morph weights need the character's bone rotations (a version 2 record)")
    head = HEADER.pack(MAGIC, CHARACTER_VERSION if section else VERSION, KINDS[record.kind], rot.shape[1],
                       expr.shape[1], float(record.fps), int(record.start), T, len(meta))
    return b"".join([head, section, rot.tobytes(), root.tobytes(), expr.tobytes(), *bones, meta])


def decode(data: bytes, source: str = "motion data") -> MotionRecord:
    """The record in `data`; a `MotionFormatError` naming `source` when the bytes are not one."""
    if len(data) < HEADER.size:
        raise MotionFormatError(f"{source}: {len(data)} bytes, shorter than the {HEADER.size}-byte header of a "
                                "GestureLSM motion record")
    magic, version, code, J, E, fps, start, T, n_meta = HEADER.unpack_from(data)
    if magic != MAGIC:
        raise MotionFormatError(f"{source}: not a GestureLSM motion record (it starts with {magic!r}, "
                                f"not {MAGIC!r})")
    if version not in (VERSION, CHARACTER_VERSION):
        raise MotionFormatError(f"{source}: motion format version {version}; this reader knows versions {VERSION} "
                                f"and {CHARACTER_VERSION} (update the app or rewrite the file)")
    kind = next((k for k, c in KINDS.items() if c == code), None)
    if kind is None:
        raise MotionFormatError(f"{source}: unknown motion kind {code} (1 = quaternion, 2 = axis-angle)")
    at, B, F = HEADER.size, 0, 0
    if version == CHARACTER_VERSION:
        if len(data) < at + SECTION.size:
            raise MotionFormatError(f"{source}: {len(data)} bytes, shorter than the headers of a version 2 record")
        B, F = SECTION.unpack_from(data, at)
        at += SECTION.size
    widths = (J * CHANNELS[kind], 3, E) + ((B * 4, 3, F) if version == CHARACTER_VERSION else ())
    want = at + 4 * T * sum(widths) + n_meta
    if len(data) != want:
        raise MotionFormatError(f"{source}: {len(data)} bytes, but its header says {want} ({T} frames of {J} "
                                f"joints, {E} expressions, {B} character bones and {F} morph weights, {n_meta} bytes "
                                "of meta): the data is cut or padded")
    floats = np.frombuffer(data, "<f4", T * sum(widths), at)
    rot, root, expr, *section = np.split(floats, np.cumsum([T * w for w in widths[:-1]]))
    meta = {}
    if n_meta:
        try:
            meta = json.loads(bytes(data[want - n_meta:]).decode())
        except (UnicodeDecodeError, ValueError):
            raise MotionFormatError(f"{source}: its meta block is not UTF-8 JSON") from None
        if not isinstance(meta, dict):
            raise MotionFormatError(f"{source}: its meta block is not a JSON object")
    bones = (section[0].reshape(T, B, 4), section[1].reshape(T, 3)) if section else (None, None)
    morph = section[2].reshape(T, F) if section and F else None
    return MotionRecord(rot.reshape(T, J, CHANNELS[kind]), root.reshape(T, 3), expr.reshape(T, E), kind=kind,
                        fps=float(fps), start=int(start), meta=meta, bone_rotations=bones[0], bone_root=bones[1],
                        morph=morph)


__all__ = ["AXIS_ANGLE", "CHARACTER_VERSION", "HEADER", "SECTION", "MAGIC", "MotionFormatError", "MotionRecord",
           "QUATERNION", "VERSION", "decode",
           "encode"]
