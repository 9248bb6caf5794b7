"""The Live Link Face CSV: the file Epic's Live Link Face app exports for a take, which Unreal's Live Link Face
importer turns into a face animation (MetaHuman) and Blender / Maya / Unity importers read.

Layout: a header row, then one row per frame:
    Timecode,BlendShapeCount,EyeBlinkLeft,...,TongueOut,HeadYaw,HeadPitch,HeadRoll,LeftEyeYaw,LeftEyePitch,
    LeftEyeRoll,RightEyeYaw,RightEyePitch,RightEyeRoll
the 52 ARKit names in the app's column order and capitalisation (`arkit.ARKIT_NAMES`; note JawRight before
JawLeft, MouthRight before MouthLeft), BlendShapeCount 61 (52 weights + 9 rotations). Timecode
`HH:MM:SS:FF.sss`: hours, minutes, seconds, the frame within the second at the motion's fps, and after the dot the
sub-frame fraction (three digits); generated frames sit on whole frames, so it is `.000` and frame 0 is
00:00:00:00.000. Weights in [0, 1] and rotations in radians, six decimals (see `arkit.py` for what each one
measures and the rotations' signs).

    export_arkit(seq, "face.csv")                 # measure the motion's face and write the file
    face = read_live_link_csv("face.csv", fps=30) # ArkitFace: weights (T, 52), head (T, 3), eyes (T, 6)
The reader finds columns by name (any capitalisation), so it also reads files whose columns are ordered
differently; the weights come back in ARKIT_NAMES order.

Live, the same face goes to Unreal's Live Link Face source (the legacy ARKit one; UDP, port 11111) as one packet
per frame (`live_link_packet`), big-endian: version (uint8) 6; the device id and the subject name, each an int32
byte length then UTF-8 bytes; frame number (int32), sub-frame (float32), fps numerator and denominator (int32);
count (uint8) 61; then 61 float32: the 52 blendshapes in Unreal's EARKitBlendShape order (UNREAL_ORDER: JawLeft
before JawRight and MouthLeft before MouthRight, unlike the CSV), head yaw / pitch / roll, left eye yaw / pitch /
roll, right eye yaw / pitch / roll (radians, as in the CSV).
"""
from __future__ import annotations

import csv
import re
import struct
from pathlib import Path

import numpy as np

from ..errors import InputError, UserError
from ..motion.sequence import MotionSequence
from .arkit import ARKIT_NAMES, EYE_NAMES, HEAD_NAMES, ArkitFace, arkit_face
from .guard import check_motion, check_rate

HEADER: tuple[str, ...] = ("Timecode", "BlendShapeCount") + ARKIT_NAMES + HEAD_NAMES + EYE_NAMES
BLEND_SHAPE_COUNT = len(ARKIT_NAMES) + len(HEAD_NAMES) + len(EYE_NAMES)           # 61
# Unreal's EARKitBlendShape order: the CSV's with JawLeft / JawRight and MouthLeft / MouthRight swapped
UNREAL_ORDER: tuple[str, ...] = tuple({"JawRight": "JawLeft", "JawLeft": "JawRight", "MouthRight": "MouthLeft",
                                       "MouthLeft": "MouthRight"}.get(n, n) for n in ARKIT_NAMES)
_UNREAL_INDEX = np.array([ARKIT_NAMES.index(n) for n in UNREAL_ORDER])
PACKET_VERSION = 6
_TIMECODE = re.compile(r"^(\d+):(\d\d):(\d\d):(\d+)(?:\.(\d+))?$")


def timecode(frame: int, fps: int) -> str:
    """Frame number -> `HH:MM:SS:FF.000` at `fps` (frame 0 = 00:00:00:00.000)."""
    seconds, ff = divmod(int(frame), int(fps))
    minutes, ss = divmod(seconds, 60)
    hh, mm = divmod(minutes, 60)
    return f"{hh:02d}:{mm:02d}:{ss:02d}:{ff:02d}.000"


def timecode_frame(code: str, fps: int) -> float:
    """`HH:MM:SS:FF[.sss]` -> the frame number at `fps` (the fraction after the dot is a sub-frame)."""
    m = _TIMECODE.match(code.strip())
    if not m:
        raise InputError(f"{code!r} is not a Live Link Face timecode (HH:MM:SS:FF.sss)")
    hh, mm, ss, ff = (int(g) for g in m.groups()[:4])
    sub = float(f"0.{m.group(5)}") if m.group(5) else 0.0
    return (hh * 3600 + mm * 60 + ss) * fps + ff + sub


def write_live_link_csv(face: ArkitFace, path: str | Path) -> Path:
    """Write `face` in the Live Link Face CSV layout; returns the path. An unwritable path is a UserError."""
    path = Path(path)
    if path.suffix.lower() != ".csv":
        raise UserError(f"{path}: use a .csv file name for the Live Link Face CSV")
    values = np.concatenate([face.weights, face.head, face.eyes], 1)
    if not np.isfinite(values).all():
        raise InputError("the face has NaN or infinite values")
    if len(values) == 0:
        raise InputError("the face has no frames; nothing is written")
    check_rate(face.fps, "the face")
    lines = [",".join(HEADER)]
    for t, row in enumerate(values):
        lines.append(f"{timecode(t, face.fps)},{BLEND_SHAPE_COUNT}," + ",".join(f"{x + 0.0:.6f}" for x in row))
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("\n".join(lines) + "\n")
    except OSError as exc:
        raise UserError(f"cannot write {path}: {exc.strerror or exc}") from None
    return path


def export_arkit(seq: MotionSequence, path: str | Path, body=None) -> Path:
    """Measure the motion's face as ARKit blendshapes (`arkit.arkit_face`) and write the Live Link Face CSV."""
    if Path(path).suffix.lower() != ".csv":
        raise UserError(f"{path}: use a .csv file name for the Live Link Face CSV")
    check_motion(seq)
    return write_live_link_csv(arkit_face(seq, body), path)


def read_live_link_csv(path: str | Path, fps: int = 30) -> ArkitFace:
    """A Live Link Face CSV -> ArkitFace (weights in ARKIT_NAMES order, head, eyes, the rows' timecodes). `fps`:
    the rate the file was recorded at (the file does not say; the app records at 60 or 30, our exports at the
    motion's). Rotation columns the file lacks read as 0; a missing blendshape column or a bad value is a
    UserError that names the file."""
    path = Path(path)
    try:
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"cannot read {path}: {getattr(exc, 'strerror', None) or exc}") from None
    if not rows or not rows[0] or rows[0][0].strip().lower() != "timecode":
        raise UserError(f"{path}: not a Live Link Face CSV (the first column is not Timecode)")
    col = {name.strip().lower(): i for i, name in enumerate(rows[0])}
    missing = [n for n in ARKIT_NAMES if n.lower() not in col]
    if missing:
        raise UserError(f"{path}: not a Live Link Face CSV (no column {missing[0]})")
    rows = [r for r in rows[1:] if any(c.strip() for c in r)]
    names = ARKIT_NAMES + HEAD_NAMES + EYE_NAMES
    values = np.zeros((len(rows), len(names)))
    for t, r in enumerate(rows):
        for k, name in enumerate(names):
            i = col.get(name.lower())
            if i is None:
                continue
            try:
                values[t, k] = float(r[i])
            except (IndexError, ValueError):
                raise UserError(f"{path}: row {t + 2} has no number in column {name}") from None
    n = len(ARKIT_NAMES)
    return ArkitFace(values[:, :n], values[:, n:n + 3], values[:, n + 3:], int(fps),
                     tuple(r[0].strip() for r in rows))


def live_link_packet(face: ArkitFace, t: int, frame_number: int, device: str = "gesturelsm",
                     subject: str = "gesturelsm") -> bytes:
    """Frame `t` of `face` as one Live Link Face UDP packet (module docstring), numbered `frame_number` at the
    face's fps (numerator fps, denominator 1)."""
    values = np.concatenate([face.weights[t][_UNREAL_INDEX], face.head[t], face.eyes[t]])
    dev, sub = device.encode("utf-8"), subject.encode("utf-8")
    return (struct.pack(f">Bi{len(dev)}si{len(sub)}s", PACKET_VERSION, len(dev), dev, len(sub), sub)
            + struct.pack(">ifiiB", int(frame_number), 0.0, int(face.fps), 1, BLEND_SHAPE_COUNT)
            + struct.pack(f">{BLEND_SHAPE_COUNT}f", *values.astype(np.float64)))
