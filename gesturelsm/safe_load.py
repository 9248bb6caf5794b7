"""Loading operator-supplied files without running code from them.

A pickle can call any importable function while it is read, so a checkpoint or model file from elsewhere
is an executable. Here:

- `load_tensors`: `torch.load(weights_only=True)`: tensors, numbers, strings and containers of them only
  (resume states and EMAGE's encoder weights need no more); anything else is a `ValueError` saying so.
- `load_npz`: every member of an .npz; plain arrays are read with `allow_pickle=False`, and members that
  are pickled object arrays (SMPL-X files carry a few, e.g. dicts of joint names) are unpickled by
  `PlainDataUnpickler`.
- `PlainDataUnpickler`: the one allow-list for pickles, `ALLOWED_GLOBALS`: numpy's array/dtype/scalar
  reconstruction, plain containers (dicts, lists, strings and numbers need no global) and bytes as protocols 0-2
  store them (`_codecs.encode`), plus the stand-in classes a caller names (the authors' vocabulary,
  `reference/released_files.py`, becomes an inert record), also when built through `copyreg._reconstructor` (how
  protocols 0-1 store an instance). Python 2 names (`__builtin__`, `copy_reg`) are compared under their Python 3
  names. A pickle naming any other global is refused (`UnsafePickleError`) before that global is looked up, so its
  code never runs.
"""
from __future__ import annotations

import _compat_pickle
import ast
import io
import pickle
import re
import zipfile
from pathlib import Path
from typing import IO, Any, Mapping

import numpy as np

from .errors import InputError

ALLOWED_GLOBALS = {
    ("numpy.core.multiarray", "_reconstruct"), ("numpy._core.multiarray", "_reconstruct"),
    ("numpy.core.multiarray", "scalar"), ("numpy._core.multiarray", "scalar"),
    ("numpy", "ndarray"), ("numpy", "dtype"),
    ("numpy.core.numeric", "_frombuffer"), ("numpy._core.numeric", "_frombuffer"),
    ("collections", "OrderedDict"), ("collections", "defaultdict"), ("builtins", "set"), ("builtins", "frozenset"),
    ("builtins", "dict"), ("builtins", "list"), ("builtins", "tuple"), ("_codecs", "encode"),
}


class UnsafePickleError(InputError):
    """A pickle that would need more than plain data to be read."""


class PlainDataUnpickler(pickle.Unpickler):
    """Builds plain data only: ALLOWED_GLOBALS, and `stand_ins` ({(module, name): class}) in place of the classes
    they name."""

    def __init__(self, file: IO[bytes], stand_ins: Mapping[tuple[str, str], type] | None = None):
        super().__init__(file)
        self.stand_ins = dict(stand_ins or {})

    def find_class(self, module: str, name: str) -> Any:
        module, name = _compat_pickle.NAME_MAPPING.get((module, name), (module, name))
        module = _compat_pickle.IMPORT_MAPPING.get(module, module)
        if (module, name) in self.stand_ins:
            return self.stand_ins[module, name]
        if (module, name) == ("builtins", "object"):
            return object
        if (module, name) == ("copyreg", "_reconstructor"):
            return self._reconstruct
        if (module, name) not in ALLOWED_GLOBALS:
            raise UnsafePickleError(f"it contains a pickled reference to {module}.{name}, which is not allowed "
                                    "(only plain data is read)")
        return super().find_class(module, name)

    def _reconstruct(self, cls: Any, base: Any, state: Any) -> Any:
        """`copyreg._reconstructor` limited to what protocols 0-1 write for a plain instance of a stand-in class."""
        if cls not in self.stand_ins.values() or base is not object or state is not None:
            raise UnsafePickleError("copyreg._reconstructor is allowed only for a plain instance of a stand-in class")
        return cls()


def load_tensors(path: str | Path, map_location: Any = "cpu") -> Any:
    """`torch.load(path, weights_only=True)`; a file that needs more is refused with a clear ValueError."""
    import torch

    try:
        return torch.load(Path(path), map_location=map_location, weights_only=True)
    except pickle.UnpicklingError as exc:
        found = re.search(r"GLOBAL ([\w.]+)", str(exc))
        what = f" ({found.group(1)})" if found else ""
        raise UnsafePickleError(f"{path}: refused to load: it holds Python objects other than tensors and plain "
                         f"data{what}, and unpickling them could run code.") from None


def load_npz(path: str | Path) -> dict[str, np.ndarray]:
    """All members of an .npz as arrays, object members through PlainDataUnpickler (see the module doc)."""
    path = Path(path)
    out: dict[str, np.ndarray] = {}
    with np.load(path, allow_pickle=False) as data:
        names = list(data.files)
        for key in names:
            try:
                out[key] = data[key]
            except ValueError as exc:
                if "allow_pickle" not in str(exc):
                    raise
                out[key] = _object_member(path, key)
    return out


def _object_member(path: Path, key: str) -> np.ndarray:
    with zipfile.ZipFile(path) as zf:
        raw = zf.read(f"{key}.npy")
    f = io.BytesIO(raw)
    major, _ = np.lib.format.read_magic(f)                     # .npy: magic, header length, header dict
    size = int.from_bytes(f.read(2 if major == 1 else 4), "little")
    header = ast.literal_eval(f.read(size).decode("latin-1" if major < 3 else "utf-8"))
    if not (isinstance(header, dict) and np.dtype(header.get("descr", "f8")).hasobject):
        raise InputError(f"{path}: member {key!r} could not be read")
    try:
        arr = PlainDataUnpickler(f).load()
    except UnsafePickleError as exc:
        raise UnsafePickleError(f"{path}: member {key!r} refused: {exc}") from None
    return np.asarray(arr)


__all__ = ["ALLOWED_GLOBALS", "PlainDataUnpickler", "UnsafePickleError", "load_npz", "load_tensors"]
