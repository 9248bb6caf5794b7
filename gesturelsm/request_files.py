"""The server's folders and files, named in one place: a request's folder in the workdir (`req-` and 128 random bits,
not guessable by other visitors, deleted with the others after `keep_minutes`), and inside it the speech, the video,
each method's downloads, the player's motion files, an edit's folder and the sweep's files; the player's bodies, shared
by every page, in the workdir.

    folders = RequestFolders(workdir, keep_minutes=60)
    out = folders.new()                     # workdir/req-<32 hex digits>
    out / VIDEO, out / SPEECH, method_file(out, "gesturelsm", NPZ)
    folders.cleanup()                       # the folders older than keep_minutes: removed
"""
from __future__ import annotations

import secrets
import shutil
import time
from pathlib import Path

REQUEST_PREFIX = "req-"                     # a request's folder: req-<32 hex digits>
BODIES = "player-bodies"                    # the player's body meshes, by body shape, shared by every page
VIDEO = "gestures.mp4"                      # the side-by-side video
SPEECH = "speech.wav"                       # the speech as the player plays it
SWEEP = "sweep"                             # a sweep's files: sweep.csv, .md, .json, .png
UPLOADS = "uploads"                         # a replica's copy of the visitor's files
NPZ, BVH = ".npz", ".bvh"                   # each method's downloads: METHOD.npz, METHOD.bvh
GLB, KEYPOINTS, ARKIT = ".glb", "_keypoints.json", "_arkit.csv"    # the first method's too


def request_name() -> str:
    """A new request folder's name (128 random bits)."""
    return f"{REQUEST_PREFIX}{secrets.token_hex(16)}"


def method_file(folder: Path, method: str, kind: str) -> Path:
    """A method's download in `folder`: `kind` one of NPZ, BVH, GLB, KEYPOINTS, ARKIT."""
    return Path(folder) / f"{method}{kind}"


def edit_name(number: int) -> str:
    """The folder of a request's `number`-th edit, inside the request's folder."""
    return f"edit-{number}-{secrets.token_hex(4)}"


def player_file(index: int, method: str) -> str:
    """The player's motion file of the `index`-th shown method."""
    return f"player-{index}-{method}.bin"


def player_before(index: int, edited: str) -> str:
    """The player's motion file of an edited method before its edit (the A/B button)."""
    return f"player-{index}-{edited}-before.bin"


def player_partial(index: int, method: str, frames: int) -> str:
    """The player's motion file of a method being made, its first `frames` frames."""
    return f"player-{index}-{method}-upto-{frames}.bin"


class RequestFolders:
    """The request folders of one workdir: `new` makes one, `cleanup` deletes the old ones."""

    def __init__(self, workdir: str | Path, keep_minutes: float):
        self.workdir = Path(workdir)
        self.workdir.mkdir(parents=True, exist_ok=True)
        self.keep_minutes = keep_minutes

    def new(self) -> Path:
        out = self.workdir / request_name()
        out.mkdir(parents=True)
        return out

    def cleanup(self, max_age_s: float | None = None) -> int:
        """Delete request folders older than keep_minutes (or `max_age_s`); returns how many were removed."""
        age = self.keep_minutes * 60 if max_age_s is None else max_age_s
        now, removed = time.time(), 0
        for d in self.workdir.glob(f"{REQUEST_PREFIX}*"):
            try:
                if now - d.stat().st_mtime > age:
                    shutil.rmtree(d, ignore_errors=True)
                    removed += 1
            except FileNotFoundError:
                continue
        return removed


__all__ = ["ARKIT", "BODIES", "BVH", "GLB", "KEYPOINTS", "NPZ", "REQUEST_PREFIX", "RequestFolders", "SPEECH", "SWEEP",
           "UPLOADS", "VIDEO", "edit_name", "method_file", "player_before", "player_file", "player_partial",
           "request_name"]
