"""The one reader of motion files (`MotionSequence.load` calls it; every command and page path that reads a motion
goes through that): a BEAT2-layout .npz from anyone, read with bounded memory and one line for each problem.

How it reads: the .npz is a zip of .npy members. Each member it uses is opened and only its .npy header (magic,
dtype, shape) is read first (np.lib.format.read_magic / read_array_header_*); every dtype, shape and frame count is
checked before any array's data is read, and then exactly that many bytes are read (a member that claims fewer
bytes than its header, or a deflate bomb, cannot make it read more). Nothing is ever unpickled: an object array is
refused from its header. Members it does not use (BEAT2's `model`, `gender`, anything else) are never read.

What it takes (docs/HOSTILE.md lists the crafted files it was tried with and what each gets):

- `poses` (T, 165), `trans` (T, 3): required; `expressions` (T, E) optional (E <= 100 is padded with zeros to 100,
  more are cut to 100), `betas` (B,) optional (padded or cut to 300). Real floating-point values only (float16,
  float32, float64, either byte order; integers, complex numbers, strings and objects are refused), every value
  finite and within `LIMITS` (a component beyond them is no rotation, position or coefficient any tool writes, and
  the body model's products of such values overflow float32).
- 1 <= T <= MAX_FRAMES (108,000: an hour at 30 fps, `constants.MAX_MOTION_SECONDS`, above the longest motion the
  package makes: `generate --max-seconds` cannot be raised past it), and T / rate <= MAX_MOTION_SECONDS.
- `mocap_frame_rate`: optional (30), one number (0-d as BEAT2 writes it, int or float; or one element), finite,
  within MIN_RATE-MAX_RATE fps. A file at another rate than 30 fps is resampled to 30 fps on load by every command
  (rotations by spherical interpolation, translation and expressions linearly; `MotionData.source_fps` keeps the
  file's rate), so the commands and the writers only ever see 30 fps.
- The speech it was made with, when `gesturelsm generate` or the page wrote it: `transcript` (0-d unicode),
  `words` (1-d unicode) and `word_times` (N x 2 float, seconds: start, end); optional, checked the same way
  (lengths bounded, times finite, 0 <= start <= end <= the motion's length + 1 s).

Every problem is a MotionFileError (a GestureError: one line, exit status 2 on the command line) naming the file
and what to change.
"""
from __future__ import annotations

import io
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import cast

import numpy as np
import torch

from ..constants import FPS, MAX_MOTION_SECONDS
from ..errors import MotionFileError
from .rotations import axis_angle_to_matrix, matrix_to_axis_angle

NUM_POSE = 165                       # 55 SMPL-X joints x axis-angle
NUM_EXPRESSIONS = 100
NUM_BETAS = 300
MAX_FRAMES = int(MAX_MOTION_SECONDS * FPS)          # 108,000
MIN_RATE, MAX_RATE = 10.0, 1000.0    # frames per second a file may state (resampled to 30)
MAX_BETAS = 10_000                   # betas values in a file (300 are used)
MAX_EXPRESSIONS = 1_000              # expression coefficients per frame in a file (100 are used)
MAX_TRANSCRIPT_CHARS = 200_000       # the transcript's characters
MAX_WORD_CHARS = 200                 # one word's characters
WORDS_PER_SECOND = 20                # words per second of motion (+ 100): far above speech's 2-4 per second
WORD_TIME_SLACK = 1.0                # seconds a word may end after the motion (the speech may be that much longer)
# largest magnitude of each array's values: axis-angle radians, metres, FLAME / SMPL-X coefficients
LIMITS = {"poses": 1000.0, "trans": 1000.0, "expressions": 1000.0, "betas": 1000.0}
_CHUNK = 8192                        # frames resampled at once (bounded memory for an hour of motion)


@dataclass
class MotionData:
    """A motion file's checked arrays, at 30 fps (float32)."""
    poses: np.ndarray                # (T, 165)
    trans: np.ndarray                # (T, 3)
    expressions: np.ndarray          # (T, 100)
    betas: np.ndarray                # (300,)
    source_fps: float                # the file's rate (resampled to FPS when it differs)
    transcript: str | None = None
    words: tuple[tuple[str, float, float], ...] = ()


def read_motion_file(path: str | Path) -> MotionData:
    """The checked motion of a BEAT2-layout .npz (see the module docstring); MotionFileError for anything else."""
    path = Path(path)
    name = str(path)
    if not path.exists():
        raise MotionFileError(f"{path}: file not found")
    if not path.is_file():
        raise MotionFileError(f"{path}: not a file (a BEAT2-layout .npz motion file, as `gesturelsm generate` "
                              "writes)")
    try:
        with open(path, "rb") as fh:
            head = fh.read(6)
    except OSError as exc:
        raise MotionFileError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    if head == b"\x93NUMPY":
        raise MotionFileError(f"{name}: one array, not a .npz motion file with 'poses' and 'trans' arrays")
    try:
        zf = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, OSError, ValueError, EOFError):
        raise MotionFileError(f"{name}: not a .npz motion file (a BEAT2-layout .npz with 'poses' and 'trans' "
                              "arrays, as `gesturelsm generate` writes)") from None
    with zf:
        return _Reader(zf, name).read()


Header = tuple[tuple[int, ...], bool, np.dtype]       # an .npy member's shape, Fortran order and dtype


class _Reader:
    def __init__(self, zf: zipfile.ZipFile, name: str) -> None:
        self.zf, self.name = zf, name
        self.members: dict[str, zipfile.ZipInfo] = {}
        for info in zf.infolist():
            key = info.filename[:-4] if info.filename.endswith(".npy") else info.filename
            self.members.setdefault(key, info)

    def fail(self, message: str) -> MotionFileError:
        return MotionFileError(f"{self.name}: {message}")

    # ---- headers ------------------------------------------------------------------------------------------
    def required(self, key: str) -> Header:
        """`header(key)` of an array every motion file has (poses, trans)."""
        head = self.header(key)
        if head is None:
            has = ", ".join(sorted(self.members)[:12]) or "no arrays"
            raise self.fail(f"missing array '{key}' (has: {has}); a motion file is a BEAT2-layout .npz with "
                            "'poses' (T, 165) and 'trans' (T, 3)")
        return head

    def header(self, key: str) -> Header | None:
        """(shape, fortran_order, dtype) of member `key` from its .npy header only; None when absent."""
        info = self.members.get(key)
        if info is None:
            return None
        try:
            with self.zf.open(info) as fh:
                version = np.lib.format.read_magic(fh)
                if version == (1, 0):
                    shape, fortran, dtype = np.lib.format.read_array_header_1_0(fh)
                elif version == (2, 0):
                    shape, fortran, dtype = np.lib.format.read_array_header_2_0(fh)
                else:
                    raise ValueError(f"npy version {version}")
        except NotImplementedError:      # encrypted or an unsupported compression
            raise self.fail(f"'{key}' is stored in a way numpy's .npz files never are (encrypted or an unknown "
                            "compression)") from None
        except (ValueError, EOFError, zipfile.BadZipFile, zlib.error, OSError, SyntaxError, TypeError) as exc:
            raise self.fail(f"'{key}' is not a readable .npy array ({_short(exc)})") from None
        if dtype.hasobject:
            raise self.fail(f"'{key}' holds Python objects (a pickle); a motion file holds plain numbers and "
                            "strings, and pickles are never loaded (they can run code)")
        if dtype.fields is not None or dtype.subdtype is not None:
            raise self.fail(f"'{key}' is a structured array ({dtype}); a motion's arrays are plain numbers")
        return tuple(int(n) for n in shape), bool(fortran), dtype

    def data(self, key: str, shape: tuple[int, ...], fortran: bool, dtype: np.dtype) -> np.ndarray:
        """Member `key`'s values: exactly the bytes its (checked) header states, read after the header."""
        count = int(np.prod(shape, dtype=np.int64))
        nbytes = count * dtype.itemsize
        try:
            with self.zf.open(self.members[key]) as member:
                fh = cast(io.BufferedIOBase, member)       # a ZipExtFile: it reads into a buffer
                version = np.lib.format.read_magic(fh)
                (np.lib.format.read_array_header_1_0 if version == (1, 0)
                 else np.lib.format.read_array_header_2_0)(fh)
                raw = bytearray(nbytes)              # writable, so the arrays are too (no second copy)
                view, got = memoryview(raw), 0
                while got < nbytes:
                    n = fh.readinto(view[got:])
                    if not n:
                        break
                    got += n
        except (ValueError, EOFError, zipfile.BadZipFile, zlib.error, OSError) as exc:
            raise self.fail(f"'{key}' is damaged ({_short(exc)})") from None
        if got != nbytes:
            raise self.fail(f"'{key}' is cut short: its header states {nbytes} bytes of data, the file holds "
                            f"{got}")
        arr = np.frombuffer(raw, dtype=dtype, count=count)
        return arr.reshape(shape[::-1]).transpose() if fortran else arr.reshape(shape)

    def floats(self, key: str, head, what: str) -> np.ndarray:
        shape, fortran, dtype = head
        if dtype.kind != "f" or dtype.itemsize > 8:
            raise self.fail(f"'{key}' holds {_kind(dtype)}; {what} must be real floating-point numbers (float32 or "
                            "float64)")
        arr = self.data(key, shape, fortran, dtype)
        arr = arr.astype(np.float32 if dtype.itemsize <= 4 else np.float64, copy=not arr.dtype.isnative)
        bad = ~np.isfinite(arr)
        if bad.any():
            raise self.fail(f"'{key}' holds {int(bad.sum())} NaN or infinite value(s); a motion's values must be "
                            "finite numbers")
        limit = LIMITS[key]
        if arr.size and float(np.abs(arr).max()) > limit:
            raise self.fail(f"'{key}' holds values up to {float(np.abs(arr).max()):.3g}, beyond +-{limit:g} "
                            f"({_UNITS[key]}): not a motion")
        return arr

    # ---- the file ---------------------------------------------------------------------------------------------
    def read(self) -> MotionData:
        heads: dict[str, Header | None] = {}
        poses_head = heads["poses"] = self.required("poses")
        trans_head = heads["trans"] = self.required("trans")
        pshape = poses_head[0]
        if len(pshape) != 2 or pshape[1] != NUM_POSE:
            raise self.fail(f"'poses' has shape {pshape}, expected (T, 165) axis-angle of the 55 SMPL-X joints")
        T = pshape[0]
        if T == 0:
            raise self.fail("the motion has no frames")
        if T > MAX_FRAMES:
            raise self.fail(f"'poses' has {T:,} frames; the limit is {MAX_FRAMES:,} ({MAX_MOTION_SECONDS / 60:g} "
                            f"minutes at {FPS} fps)")
        if trans_head[0] != (T, 3):
            raise self.fail(f"'trans' has shape {trans_head[0]}, expected ({T}, 3)")
        for key, shape_ok, expected in (
                ("expressions", lambda s: len(s) == 2 and s[0] == T and s[1] <= MAX_EXPRESSIONS,
                 f"({T}, 100)"),
                ("betas", lambda s: len(s) == 1 and s[0] <= MAX_BETAS or len(s) == 2 and s[0] == 1
                 and s[1] <= MAX_BETAS, "(300,)")):
            head = heads[key] = self.header(key)
            if head is not None and not shape_ok(head[0]):
                raise self.fail(f"'{key}' has shape {head[0]}, expected {expected}")
        rate = self.rate()
        if T / rate > MAX_MOTION_SECONDS + 1e-9:
            raise self.fail(f"the motion is {T / rate:,.0f} s long ({T:,} frames at {rate:g} fps); the limit is "
                            f"{MAX_MOTION_SECONDS:g} s")
        for key in ("poses", "trans", "expressions", "betas"):      # every header checked: now the dtypes
            head = heads[key]
            if head is not None and (head[2].kind != "f" or head[2].itemsize > 8):
                raise self.fail(f"'{key}' holds {_kind(head[2])}; a motion's {key} must be real "
                                "floating-point numbers (float32 or float64)")
        transcript, words = self.speech(T / rate)
        poses = self.floats("poses", heads["poses"], "poses")
        trans = self.floats("trans", heads["trans"], "a translation")
        if heads["expressions"] is not None:
            expr = self.floats("expressions", heads["expressions"], "expressions")
            expr = np.pad(expr, ((0, 0), (0, max(0, NUM_EXPRESSIONS - expr.shape[1]))))[:, :NUM_EXPRESSIONS]
        else:
            expr = np.zeros((T, NUM_EXPRESSIONS), np.float32)
        betas = np.zeros(NUM_BETAS, np.float32)
        if heads["betas"] is not None:
            b = self.floats("betas", heads["betas"], "betas").reshape(-1)[:NUM_BETAS]
            betas[:len(b)] = b
        poses, trans, expr = (np.asarray(a, np.float32) for a in (poses, trans, expr))
        if abs(rate - FPS) > 1e-6:
            poses, trans, expr = resample(poses, trans, expr, rate, FPS)
        return MotionData(poses, trans, expr, betas, rate, transcript, words)

    def rate(self) -> float:
        head = self.header("mocap_frame_rate")
        if head is None:
            return float(FPS)
        shape, fortran, dtype = head
        if int(np.prod(shape)) != 1:
            raise self.fail(f"'mocap_frame_rate' has shape {shape}; it is one number (frames per second, e.g. 30)")
        if dtype.kind not in "iuf":
            raise self.fail(f"'mocap_frame_rate' holds {_kind(dtype)}; it is one number (frames per second, e.g. 30)")
        rate = float(self.data("mocap_frame_rate", shape, fortran, dtype).reshape(-1)[0])
        if not np.isfinite(rate) or not MIN_RATE <= rate <= MAX_RATE:
            raise self.fail(f"'mocap_frame_rate' is {rate:g}; a motion's frame rate is {MIN_RATE:g}-{MAX_RATE:g} "
                            f"frames per second (BEAT2's is {FPS})")
        return rate

    def speech(self, seconds: float) -> tuple[str | None, tuple[tuple[str, float, float], ...]]:
        """The transcript and word timings the motion was made with, when the file keeps them."""
        transcript = None
        head = self.header("transcript")
        if head is not None:
            shape, fortran, dtype = head
            if shape != () or dtype.kind != "U":
                raise self.fail(f"'transcript' is {_kind(dtype)} of shape {shape}; it is one unicode string")
            if dtype.itemsize // 4 > MAX_TRANSCRIPT_CHARS:
                raise self.fail(f"'transcript' has {dtype.itemsize // 4:,} characters; the limit is "
                                f"{MAX_TRANSCRIPT_CHARS:,}")
            transcript = str(self.data("transcript", shape, fortran, dtype)[()]) or None
        wh, th = self.header("words"), self.header("word_times")
        if wh is None and th is None:
            return transcript, ()
        if wh is None or th is None:
            raise self.fail("'words' and 'word_times' go together (the words and their start and end times); the "
                            f"file has only '{'words' if th is None else 'word_times'}'")
        limit = int(100 + WORDS_PER_SECOND * seconds)
        if len(wh[0]) != 1 or wh[2].kind != "U":
            raise self.fail(f"'words' is {_kind(wh[2])} of shape {wh[0]}; it is a list of unicode strings")
        n = wh[0][0]
        if n > limit:
            raise self.fail(f"'words' has {n:,} words; a motion of {seconds:.0f} s keeps at most {limit:,}")
        if wh[2].itemsize // 4 > MAX_WORD_CHARS:
            raise self.fail(f"'words' holds words of up to {wh[2].itemsize // 4:,} characters; the limit is "
                            f"{MAX_WORD_CHARS}")
        if th[0] != (n, 2) or th[2].kind != "f":
            raise self.fail(f"'word_times' is {_kind(th[2])} of shape {th[0]}; it is ({n}, 2) seconds (start, end)")
        words = self.data("words", *wh)
        times = self.data("word_times", *th).astype(np.float64)
        if not np.isfinite(times).all():
            raise self.fail("'word_times' holds NaN or infinite values")
        if n and ((times[:, 0] < 0).any() or (times[:, 1] < times[:, 0]).any()
                  or times.max() > seconds + WORD_TIME_SLACK):
            raise self.fail(f"'word_times' holds times outside the motion (0-{seconds:.2f} s) or words that end "
                            "before they start")
        return transcript, tuple((str(w), float(a), float(b)) for w, (a, b) in zip(words, times))


_UNITS = {"poses": "radians", "trans": "metres", "expressions": "FLAME coefficients", "betas": "shape coefficients"}


def _kind(dtype: np.dtype) -> str:
    kinds = {"b": "booleans", "i": "integers", "u": "integers", "c": "complex numbers", "U": "strings",
             "S": "byte strings", "V": "raw bytes", "M": "dates", "m": "time spans", "f": "floating-point numbers"}
    return f"{kinds.get(dtype.kind, 'values')} ({dtype.name})"


def _short(exc: BaseException) -> str:
    text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    return text[:160]


def resample(poses: np.ndarray, trans: np.ndarray, expr: np.ndarray, rate: float, fps: int = FPS
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A motion at `rate` frames per second at `fps`: frame k at k / fps s (as many as fit in the motion, at least
    one); rotations by spherical interpolation between the two nearest frames, translation and expressions
    linearly. Works in chunks of frames, so an hour of motion needs little memory."""
    T = len(poses)
    n = max(1, int(np.floor((T - 1) * fps / rate + 1e-9)) + 1)
    out_p = np.empty((n, poses.shape[1]), np.float32)
    src = np.arange(n, dtype=np.float64) * rate / fps                      # source frame of each output frame
    i0 = np.minimum(np.floor(src).astype(np.int64), T - 1)
    i1 = np.minimum(i0 + 1, T - 1)
    w = (src - i0).astype(np.float32)
    for a in range(0, n, _CHUNK):
        s = slice(a, min(n, a + _CHUNK))
        r0 = axis_angle_to_matrix(torch.from_numpy(poses[i0[s]].reshape(-1, 55, 3)))
        r1 = axis_angle_to_matrix(torch.from_numpy(poses[i1[s]].reshape(-1, 55, 3)))
        step = matrix_to_axis_angle(r0.transpose(-1, -2) @ r1) * torch.from_numpy(w[s]).view(-1, 1, 1)
        out_p[s] = matrix_to_axis_angle(r0 @ axis_angle_to_matrix(step)).reshape(-1, poses.shape[1]).numpy()
    wc = w[:, None]
    out_t = (trans[i0] * (1 - wc) + trans[i1] * wc).astype(np.float32)
    out_e = (expr[i0] * (1 - wc) + expr[i1] * wc).astype(np.float32)
    return out_p, out_t, out_e


__all__ = ["LIMITS", "MAX_FRAMES", "MAX_RATE", "MIN_RATE", "MotionData", "read_motion_file", "resample"]
