"""Crafted motion files for the hardening tests (docs/HOSTILE.md lists each with what it gets), made in
well under a second each without the package: every way a BEAT2-layout .npz from a stranger can be wrong.

`HOSTILE` maps a name to (a function writing the file at a path, the words the refusal must contain);
`ACCEPTED` the unusual but valid files BEAT2 and other tools write (a function, the frame count they load as).
`BOMBS` are the names whose data would take gigabytes if read.
"""
from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

T = 40                                   # frames of the small crafted motions


def npy_header(shape: tuple, descr: str, fortran: bool = False) -> bytes:
    """A .npy version 1.0 header stating `shape` and `descr`, whatever data follows."""
    text = f"{{'descr': {descr!r}, 'fortran_order': {fortran}, 'shape': {tuple(shape)!r}, }}"
    pad = 64 - (10 + len(text) + 1) % 64
    text = text + " " * pad + "\n"
    return b"\x93NUMPY\x01\x00" + len(text).to_bytes(2, "little") + text.encode("latin1")


def write_npz(path: Path, members: dict, deflate: bool = False) -> Path:
    """A zip of .npy members: arrays written by numpy (objects pickled, as np.savez would), bytes as they are."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED if deflate else zipfile.ZIP_STORED) as zf:
        for key, value in members.items():
            with zf.open(f"{key}.npy", "w", force_zip64=True) as fh:
                if isinstance(value, bytes):
                    fh.write(value)
                else:
                    np.lib.format.write_array(fh, np.asanyarray(value), allow_pickle=True)
    return path


def motion(frames: int = T, **over) -> dict:
    """A valid small motion's members (BEAT2's keys), with `over` replacing or adding (None removes)."""
    rng = np.random.default_rng(0)
    out = {"poses": (rng.normal(size=(frames, 165)) * 0.2).astype(np.float32),
           "trans": np.tile(np.array([0.0, 0.9, 0.0], np.float32), (frames, 1)),
           "expressions": np.zeros((frames, 100), np.float32), "betas": np.zeros(300, np.float32),
           "model": np.array("smplx2020"), "gender": np.array("neutral"),
           "mocap_frame_rate": np.array(30, np.int32)}
    out.update(over)
    return {k: v for k, v in out.items() if v is not None}


def _bomb(path: Path, frames: int = 2_000_000) -> Path:
    """`frames` zero frames of poses, deflated: ~1.3 MB on disk, 1.3 GB read."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as zf:
        for key, value in motion(frames=1, poses=None, trans=None).items():
            with zf.open(f"{key}.npy", "w") as fh:
                np.lib.format.write_array(fh, value)
        for key, width in (("poses", 165), ("trans", 3)):
            with zf.open(f"{key}.npy", "w", force_zip64=True) as fh:
                fh.write(npy_header((frames, width), "<f4"))
                chunk = bytes(4 * width * 10_000)
                for _ in range(frames // 10_000):
                    fh.write(chunk)
    return path


def _claims(frames: int) -> callable:
    """Headers that claim `frames` frames over a few bytes of data."""
    return lambda p: write_npz(p, motion(poses=npy_header((frames, 165), "<f4") + bytes(64),
                                         trans=npy_header((frames, 3), "<f4") + bytes(64)))


def _members(**over) -> callable:
    return lambda p: write_npz(p, motion(**over))


def _structured() -> np.ndarray:
    return np.zeros(T, dtype=[("a", "<f4", (165,))])


def _cut_real(p: Path) -> Path:
    whole = Path(p.parent / "whole.npz")
    write_npz(whole, motion())
    p.write_bytes(whole.read_bytes()[: len(whole.read_bytes()) // 2])
    whole.unlink()
    return p


def _short_member(p: Path) -> Path:
    return write_npz(p, motion(poses=npy_header((T, 165), "<f4") + bytes(4 * 165 * 3)))


HOSTILE: dict[str, tuple] = {
    "deflate bomb: 2,000,000 zero frames (1.3 GB) in a 6 MB file": (_bomb, "2,000,000 frames; the limit is 108,000"),
    "header claiming 10^9 frames": (_claims(10**9), "1,000,000,000 frames; the limit is 108,000"),
    "header claiming 108,001 frames": (_claims(108_001), "108,001 frames; the limit is 108,000"),
    "poses a pickled object array": (_members(poses=np.array([object()] * T, dtype=object)), "pickle"),
    "transcript a pickled object": (_members(transcript=np.array({"a": 1}, dtype=object)), "pickle"),
    "mocap_frame_rate 0": (_members(mocap_frame_rate=np.array(0)), "'mocap_frame_rate' is 0"),
    "mocap_frame_rate -30": (_members(mocap_frame_rate=np.array(-30)), "'mocap_frame_rate' is -30"),
    "mocap_frame_rate NaN": (_members(mocap_frame_rate=np.array(np.nan)), "'mocap_frame_rate' is nan"),
    "mocap_frame_rate inf": (_members(mocap_frame_rate=np.array(np.inf)), "'mocap_frame_rate' is inf"),
    "mocap_frame_rate 5 (below 10)": (_members(mocap_frame_rate=np.array(5)), "10-1000 frames per second"),
    "mocap_frame_rate 1e9": (_members(mocap_frame_rate=np.array(1e9)), "10-1000 frames per second"),
    "mocap_frame_rate an array [30, 30]": (_members(mocap_frame_rate=np.array([30, 30])), "has shape (2,)"),
    "mocap_frame_rate a string '30'": (_members(mocap_frame_rate=np.array("30")), "holds strings"),
    "0 frames": (_members(poses=np.zeros((0, 165), np.float32), trans=np.zeros((0, 3), np.float32),
                          expressions=np.zeros((0, 100), np.float32)), "no frames"),
    "poses strings": (_members(poses=np.full((T, 165), "x")), "'poses' holds strings"),
    "betas strings": (_members(betas=np.full(300, "x")), "'betas' holds strings"),
    "poses complex": (_members(poses=np.zeros((T, 165), np.complex64)), "complex numbers"),
    "poses integers": (_members(poses=np.zeros((T, 165), np.int64)), "'poses' holds integers"),
    "poses booleans": (_members(poses=np.zeros((T, 165), bool)), "'poses' holds booleans"),
    "poses float128": (_members(poses=np.zeros((T, 165), np.longdouble)), "float32 or float64"),
    "poses a structured array": (_members(poses=_structured()), "structured array"),
    "poses 1e30": (_members(poses=np.full((T, 165), 1e30, np.float32)), "beyond +-1000 (radians)"),
    "trans 1e30": (_members(trans=np.full((T, 3), 1e30, np.float32)), "beyond +-1000 (metres)"),
    "poses NaN": (_members(poses=np.full((T, 165), np.nan, np.float32)), "'poses' holds 6600 NaN"),
    "trans inf": (_members(trans=np.full((T, 3), np.inf, np.float32)), "'trans' holds 120 NaN or infinite"),
    "expressions NaN": (_members(expressions=np.full((T, 100), np.nan, np.float32)), "'expressions' holds"),
    "expressions inf": (_members(expressions=np.full((T, 100), -np.inf)), "'expressions' holds"),
    "betas NaN": (_members(betas=np.full(300, np.nan, np.float32)), "'betas' holds 300 NaN"),
    "poses (T, 72): SMPL, not SMPL-X": (_members(poses=np.zeros((T, 72), np.float32)), "expected (T, 165)"),
    "poses 3-d": (_members(poses=np.zeros((T, 55, 3), np.float32)), "expected (T, 165)"),
    "trans of other length": (_members(trans=np.zeros((T + 1, 3), np.float32)), f"expected ({T}, 3)"),
    "expressions of other length": (_members(expressions=np.zeros((T - 1, 100), np.float32)), "expected"),
    "betas claiming 10^8 values": (_members(betas=npy_header((10**8,), "<f4")), "'betas' has shape"),
    "no poses": (_members(poses=None), "missing array 'poses'"),
    "no trans": (_members(trans=None), "missing array 'trans'"),
    "words without word_times": (_members(words=np.array(["a"])), "go together"),
    "word_times NaN": (_members(words=np.array(["a"]), word_times=np.full((1, 2), np.nan, np.float32)),
                       "'word_times' holds NaN"),
    "word_times past the motion": (_members(words=np.array(["a"]), word_times=np.array([[0.0, 1e6]], np.float32)),
                                   "outside the motion"),
    "words claiming 10^7 words": (_members(words=npy_header((10**7,), "<U5"),
                                           word_times=npy_header((10**7, 2), "<f4")), "words; a motion of"),
    "member cut short": (_short_member, "cut short"),
    "zip cut in half": (_cut_real, "not a .npz motion file"),
    "text named .npz": (lambda p: p.write_text("hello") and p, "not a .npz motion file"),
    "empty file": (lambda p: p.write_bytes(b"") or p, "not a .npz motion file"),
    "one .npy array": (lambda p: np.save(p.with_suffix(".npy"), np.zeros((T, 165))) or
                       p.with_suffix(".npy").rename(p), "one array, not a .npz"),
}
BOMBS = ("deflate bomb: 2,000,000 zero frames (1.3 GB) in a 6 MB file", "header claiming 10^9 frames",
         "betas claiming 10^8 values", "words claiming 10^7 words")

ACCEPTED: dict[str, tuple] = {
    "BEAT2's own layout (float64 trans and expressions, string model / gender, 0-d int32 rate)":
        (_members(trans=np.zeros((T, 3)), expressions=np.zeros((T, 100))), T),
    "mocap_frame_rate a 0-d float 30.0": (_members(mocap_frame_rate=np.array(30.0)), T),
    "mocap_frame_rate a 0-d int64": (_members(mocap_frame_rate=np.array(30, np.int64)), T),
    "mocap_frame_rate one element [30]": (_members(mocap_frame_rate=np.array([30])), T),
    "no mocap_frame_rate, expressions or betas": (_members(mocap_frame_rate=None, expressions=None, betas=None), T),
    "60 fps: resampled to 30": (_members(mocap_frame_rate=np.array(60)), T // 2),
    "big-endian float64, Fortran order": (_members(poses=np.asfortranarray(np.zeros((T, 165), ">f8"))), T),
    "50 expressions, (1, 300) betas": (_members(expressions=np.zeros((T, 50), np.float32),
                                                betas=np.zeros((1, 300), np.float32)), T),
    "deflated (np.savez_compressed)": (lambda p: write_npz(p, motion(), deflate=True), T),
    "transcript and word timings": (_members(transcript=np.array("hello there"), words=np.array(["hello", "there"]),
                                             word_times=np.array([[0.1, 0.4], [0.5, 0.9]], np.float32)), T),
}


def make(name: str, folder: Path, table: dict | None = None) -> Path:
    """The crafted file `name` (of HOSTILE, else ACCEPTED) in `folder`."""
    table = table or (HOSTILE if name in HOSTILE else ACCEPTED)
    path = folder / (f"m{list(table).index(name):02d}.npz")
    table[name][0](path)
    return path
