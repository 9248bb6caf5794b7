"""Files that travel with tasks, and results written whole or not at all.

Workers share no disk with the machine that starts the work: a checkpoint folder, a body model or a character file
given on the command line goes to them by value; the package's own assets/ (shipped checkpoints, the mannequin) do
not travel, every worker has them (`connect.check_workers` makes sure they are the same). `Files.of(path, ship=True)`
reads the files once on the driver; on a worker `.local()` writes them once per machine under
<tmp>/gesturelsm-files/<content hash>/ (a folder renamed into place when complete, so concurrent workers never see half
a copy) and returns the path there. Not shipped (`ship=False`, a run in this process), nothing is read
and `.local()` is the original path.

`write_atomic(path, data)` is how the driver writes every result: a temporary name beside it, then a rename.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable

from ..constants import ASSETS

CACHE = "gesturelsm-files"


@dataclass(frozen=True)
class Files:
    source: str                                   # the path on the machine that made this (file or folder)
    digest: str                                   # sha256 over names and contents ("" when not shipped)
    names: tuple[str, ...] = ()                   # a folder's files (relative, posix), or the file's own name
    blobs: tuple[bytes, ...] | None = field(default=None, compare=False, repr=False)   # None: not shipped
    folder: bool = False
    shipped_assets: bool = False                  # a file of the package's own assets/: every worker has it

    @classmethod
    def of(cls, path: str | os.PathLike | None, ship: bool, only: Iterable[str] | None = None) -> "Files | None":
        """The file or folder at `path` (None -> None); `only`: these relative names of a folder. `ship`: carry the
        bytes (a task on another machine); else only the path, nothing is read."""
        if path is None:
            return None
        root = Path(path)
        if not root.exists():
            raise FileNotFoundError(f"{root} does not exist")
        if not ship:
            return cls(str(root), "", folder=root.is_dir())
        if root.resolve().is_relative_to(ASSETS.resolve()):
            return cls(root.resolve().relative_to(ASSETS.resolve()).as_posix(), "assets", folder=root.is_dir(),
                       shipped_assets=True)
        if root.is_dir():
            names = sorted(only) if only is not None else sorted(
                p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file() and "__pycache__" not in p.parts)
            paths = [root / n for n in names]
        else:
            names, paths = [root.name], [root]
        h = hashlib.sha256()
        blobs = []
        for n, p in zip(names, paths):
            data = p.read_bytes()
            h.update(f"{n}\0{len(data)}\0".encode())
            h.update(data)
            blobs.append(data)
        return cls(str(root), h.hexdigest()[:24], tuple(names), tuple(blobs), root.is_dir())

    @property
    def shipped(self) -> bool:
        return self.blobs is not None

    def local(self) -> Path:
        """A path to these files on this machine: the original when not shipped, this machine's assets/ for the
        package's own files, else the shared copy."""
        if self.shipped_assets:
            return ASSETS / self.source
        if not self.shipped:
            return Path(self.source)
        home = Path(tempfile.gettempdir()) / CACHE / self.digest
        if not home.exists():
            home.parent.mkdir(parents=True, exist_ok=True)
            part = Path(tempfile.mkdtemp(prefix=f".{self.digest}-", dir=home.parent))
            for name, data in zip(self.names, self.blobs):
                (part / name).parent.mkdir(parents=True, exist_ok=True)
                (part / name).write_bytes(data)
            try:
                part.rename(home)
            except OSError:                       # another worker on this machine finished first: same bytes
                shutil.rmtree(part, ignore_errors=True)
        return home if self.folder else home / self.names[0]


def write_atomic(path: str | os.PathLike, data: bytes) -> Path:
    """Write `data` to `path` whole or not at all: a hidden temporary file beside it, then a rename."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, 0o644)                      # as an ordinary write would leave it (mkstemp makes it 0600)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


__all__ = ["Files", "write_atomic"]
