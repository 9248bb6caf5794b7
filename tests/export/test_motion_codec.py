"""The binary motion format shared by the player's files and the live feed: encoding then decoding gives back the
record bit for bit; the header sits where the page's decoder reads it; bytes that are not a record this reader knows
give a one-line message naming the source."""
from __future__ import annotations

import json
import struct

import numpy as np
import pytest

from gesturelsm.errors import InputError
from gesturelsm.export.motion_codec import (AXIS_ANGLE, HEADER, QUATERNION, MotionFormatError, MotionRecord,
                                             decode, encode)


def _record(kind: str = QUATERNION, T: int = 7, E: int = 3, seed: int = 0) -> MotionRecord:
    rng = np.random.default_rng(seed)
    C = 4 if kind == QUATERNION else 3
    return MotionRecord(rng.normal(size=(T, 55, C)).astype(np.float32), rng.normal(size=(T, 3)).astype(np.float32),
                        rng.normal(size=(T, E)).astype(np.float32), kind=kind, fps=30.0, start=123456,
                        meta={"status": "streaming", "frames": 99, "median_latency_ms": 812.5, "note": "süß"})


@pytest.mark.parametrize("kind, T, E", [(QUATERNION, 7, 3), (AXIS_ANGLE, 5, 0), (QUATERNION, 0, 0)])
def test_round_trip_gives_back_every_field(kind, T, E):
    rec = _record(kind, T, E)
    data = encode(rec)
    got = decode(data)
    assert (got.kind, got.fps, got.start, got.frames, got.meta) == (kind, 30.0, 123456, T, rec.meta)
    for k in ("rotations", "root", "expressions"):
        assert getattr(got, k).dtype == np.float32 and getattr(got, k).shape == getattr(rec, k).shape
        np.testing.assert_array_equal(getattr(got, k), getattr(rec, k))
    assert encode(got) == data


def test_header_layout_is_the_documented_one():
    """Byte offsets the page's decoder (gesturelsm/webapp/player/src/motion_decoder.js) reads: magic, version, kind,
    joints, expressions, fps, start, frames, meta length, then the floats at byte 28."""
    rec = _record(QUATERNION, T=2, E=3)
    data = encode(rec)
    assert HEADER.size == 28 and data[:4] == b"GLSM"
    version, kind, J, E, fps, start, T, n_meta = struct.unpack_from("<HHHHfIII", data, 4)
    assert (version, kind, J, E, fps, start, T) == (1, 1, 55, 3, 30.0, 123456, 2)
    first = np.frombuffer(data, "<f4", 4, 28)
    np.testing.assert_array_equal(first, rec.rotations[0, 0])
    assert len(data) == 28 + 4 * 2 * (55 * 4 + 3 + 3) + n_meta


def test_a_record_with_only_meta():
    got = decode(encode(MotionRecord(meta={"status": "busy"})))
    assert got.frames == 0 and got.meta == {"status": "busy"} and got.rotations.shape == (0, 55, 4)


@pytest.mark.parametrize("mutate, says", [
    (lambda b: b[:10], "shorter than the 28-byte header"),
    (lambda b: b"RIFF" + b[4:], "not a GestureLSM motion record"),
    (lambda b: b[:4] + struct.pack("<H", 9) + b[6:], "motion format version 9"),
    (lambda b: b[:6] + struct.pack("<H", 7) + b[8:], "unknown motion kind 7"),
    (lambda b: b[:-5], "the data is cut or padded"),
    (lambda b: b + b"\0\0\0\0", "the data is cut or padded"),
    (lambda b: b[:-2] + b"\xff\xfe", "meta block is not UTF-8 JSON"),
])
def test_bad_bytes_say_what_is_wrong(mutate, says):
    data = mutate(encode(_record()))
    with pytest.raises(MotionFormatError, match=says) as err:
        decode(data, source="m.bin")
    assert str(err.value).startswith("m.bin: ") and "\n" not in str(err.value)
    assert isinstance(err.value, InputError)                # the app and CLI show it as a message, not a traceback


def test_meta_must_be_an_object():
    head = encode(MotionRecord(meta={"a": 1}))
    data = head[:24] + struct.pack("<I", 3) + b"[1]"
    with pytest.raises(MotionFormatError, match="not a JSON object"):
        decode(data)


def test_encoding_checks_the_shapes():
    with pytest.raises(ValueError, match="rotations must be"):
        encode(MotionRecord(np.zeros((2, 55, 3)), np.zeros((2, 3)), np.zeros((2, 0))))       # 3 numbers: axis-angle
    with pytest.raises(ValueError, match="root must be"):
        encode(MotionRecord(np.zeros((2, 55, 4)), np.zeros((3, 3)), np.zeros((2, 0))))


def test_a_character_section_round_trips_as_version_2_and_leaves_version_1_alone():
    """The live feed on a character: bone rotations and the hips' translation after the expressions, the bone count
    at byte 28; a record without a section is version 1 in version 1's layout."""
    from dataclasses import replace

    from gesturelsm.export.motion_codec import CHARACTER_VERSION, SECTION

    rec = _record(QUATERNION, T=5, E=2)
    rng = np.random.default_rng(1)
    crec = replace(rec, bone_rotations=rng.normal(size=(5, 43, 4)).astype(np.float32),
                   bone_root=rng.normal(size=(5, 3)).astype(np.float32))
    plain, data = encode(rec), encode(crec)
    meta = json.dumps(rec.meta, separators=(",", ":")).encode()
    assert plain == (HEADER.pack(b"GLSM", 1, 1, 55, 2, 30.0, 123456, 5, len(meta)) + rec.rotations.tobytes()
                     + rec.root.tobytes() + rec.expressions.tobytes() + meta)            # version 1's layout, as is
    assert struct.unpack_from("<H", data, 4)[0] == CHARACTER_VERSION == 2
    assert SECTION.unpack_from(data, 28) == (43, 0)
    np.testing.assert_array_equal(np.frombuffer(data, "<f4", 4, 32), rec.rotations[0, 0])   # floats from byte 32
    assert len(data) == len(plain) + 4 + 4 * 5 * (43 * 4 + 3)
    got = decode(data)
    for k in ("rotations", "root", "expressions", "bone_rotations", "bone_root"):
        np.testing.assert_array_equal(getattr(got, k), getattr(crec, k))
    assert got.meta == rec.meta and got.start == rec.start and decode(plain).bone_rotations is None
    assert encode(got) == data
    with pytest.raises(MotionFormatError, match="cut or padded"):
        decode(data[:-4])
    with pytest.raises(ValueError, match="bone rotations must be"):
        encode(replace(rec, bone_rotations=np.zeros((4, 43, 4)), bone_root=np.zeros((5, 3))))


def test_face_morph_weights_round_trip_after_the_hips_translation():
    """A character with face presets: F morph weights per frame after the hips' translation, F at byte 30 (0: none;
    the bone-only record); encode -> decode gives every weight back, wrong sizes are refused."""
    from dataclasses import replace

    from gesturelsm.export.motion_codec import SECTION

    rng = np.random.default_rng(2)
    T, B, F = 6, 43, 7
    bones = replace(_record(QUATERNION, T=T, E=2), bone_rotations=rng.normal(size=(T, B, 4)).astype(np.float32),
                    bone_root=rng.normal(size=(T, 3)).astype(np.float32))
    face = replace(bones, morph=rng.uniform(size=(T, F)).astype(np.float32))
    plain, data = encode(bones), encode(face)
    assert SECTION.unpack_from(plain, 28) == (B, 0) and SECTION.unpack_from(data, 28) == (B, F)
    assert len(data) == len(plain) + 4 * T * F
    n_meta = struct.unpack_from("<I", data, 24)[0]
    np.testing.assert_array_equal(np.frombuffer(data, "<f4", T * F, len(data) - n_meta - 4 * T * F).reshape(T, F),
                                  face.morph)                               # right before the meta block
    got = decode(data)
    for k in ("rotations", "root", "expressions", "bone_rotations", "bone_root", "morph"):
        np.testing.assert_array_equal(getattr(got, k), getattr(face, k))
    assert decode(plain).morph is None and encode(got) == data
    with pytest.raises(MotionFormatError, match=f"{F} morph weights.*cut or padded"):
        decode(data[:-n_meta - 4] + data[len(data) - n_meta:])
    with pytest.raises(ValueError, match="morph weights must be"):
        encode(replace(face, morph=np.zeros((T - 1, F))))
    with pytest.raises(ValueError, match="need the character's bone rotations"):
        encode(replace(_record(), morph=np.zeros((7, F))))
