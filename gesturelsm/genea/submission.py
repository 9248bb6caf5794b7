"""A GENEA Leaderboard submission: K samples per test speech file in BEAT2's SMPL-X npz layout at 30 fps, each from
its own recorded seed, a manifest of how they were made, and the checks the leaderboard's intake would make.

    OUT/<speech stem>_sample<k>.npz   k = 1..K; poses (T, 165), trans (T, 3), expressions (T, 100), betas (300,),
                                      model, gender, mocap_frame_rate = 30, T = 30 x the speech's duration (+-1)
    OUT/manifest.json                 settings, per file its speech's SHA-256 and seed, checkpoint hashes, versions

The leaderboard (rules version 2025-11-17) reads every `*.npz` of one folder and groups files by the take's name,
the first five underscore-separated parts of the file name (`2_scott_0_103_103_sample1.npz` -> `2_scott_0_103_103`);
its per-speech diversity needs at least six parts. A speech file whose stem is not a BEAT2 take's name would be
skipped there, so `check_name` refuses it here, before any work.
"""
from __future__ import annotations

import hashlib
import io
import json
import platform
import re
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..constants import FPS, SAMPLE_RATE
from ..errors import InputError

RULES = "2025-11-17"
SAMPLES = 5                                    # what the rules ask of a non-deterministic system
TAKE = re.compile(r"^\d+_[A-Za-z]+_\d+_\d+_\d+$")   # BEAT2: speaker id, name, language/kind, start, end
MANIFEST = "manifest.json"
SHAPES = {"poses": (165,), "trans": (3,), "expressions": (100,)}


def sample_name(stem: str, k: int) -> str:
    """The file of sample k (1-based) of a speech."""
    return f"{stem}_sample{k}.npz"


def take_of(file_name: str) -> str | None:
    """The take a submitted file belongs to, as the leaderboard groups them (first five '_' parts), or None."""
    parts = Path(file_name).stem.split("_")
    return "_".join(parts[:5]) if len(parts) >= 6 else None


def check_name(stem: str) -> str | None:
    """Why a speech file's stem cannot name a submission's files (None: it can)."""
    if not TAKE.match(stem):
        return (f"{stem}: not a BEAT2 take's name (like 2_scott_0_103_103); the leaderboard groups the submitted "
                "files by the take's name, the first five '_'-separated parts of the file name, and skips others")
    return None


def sample_seeds(seed: int, samples: int) -> list[int]:
    """The seeds of a speech's samples: seed, seed + 1, ... (every sample is kept: none is picked)."""
    return [seed + k for k in range(samples)]


def check_arrays(name: str, arrays: dict[str, np.ndarray], seconds: float) -> list[str]:
    """What the leaderboard would not accept in one file's arrays (empty: nothing)."""
    bad = []
    for key in ("poses", "trans", "expressions", "betas", "gender", "mocap_frame_rate"):
        if key not in arrays:
            bad.append(f"{name}: no '{key}' array")
    if bad:
        return bad
    T = len(arrays["poses"])
    for key, tail in SHAPES.items():
        a = arrays[key]
        if a.shape != (T, *tail):
            bad.append(f"{name}: '{key}' has shape {a.shape}, expected ({T}, {', '.join(map(str, tail))})")
        elif not np.issubdtype(a.dtype, np.floating) or not np.isfinite(a).all():
            bad.append(f"{name}: '{key}' is not all finite floating-point numbers")
    if int(np.asarray(arrays["mocap_frame_rate"])) != FPS:
        bad.append(f"{name}: mocap_frame_rate {arrays['mocap_frame_rate']}, the leaderboard's is {FPS}")
    want = FPS * seconds
    if abs(T - want) > 1:
        bad.append(f"{name}: {T} frames for {seconds:.2f} s of speech; expected {want:.0f} (+-1) at {FPS} fps")
    return bad


def read_arrays(data: bytes) -> dict[str, np.ndarray]:
    with np.load(io.BytesIO(data), allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def check_speech(stem: str, files: dict[str, bytes], seconds: float) -> list[str]:
    """Every problem of one speech's sample files (name -> npz bytes): names, arrays, and samples that are the same
    motion (a non-deterministic system's samples must differ; the same seed twice would not)."""
    bad = [p for p in [check_name(stem)] if p]
    poses = {}
    for name, data in files.items():
        try:
            arrays = read_arrays(data)
        except Exception as exc:                       # what np.load cannot read, the leaderboard cannot either
            bad.append(f"{name}: not a readable npz ({exc})")
            continue
        bad += check_arrays(name, arrays, seconds)
        if "poses" in arrays:
            poses[name] = arrays["poses"]
    names = sorted(poses)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if poses[a].shape == poses[b].shape and np.array_equal(poses[a], poses[b]):
                bad.append(f"{a} and {b} are the same motion; the samples of a speech must be independent draws")
    return bad


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def checkpoint_hashes(sources: list[Path], method: str) -> dict[str, str]:
    """SHA-256 of every model file under the checkpoint sources the method loads from (file -> hash)."""
    out = {}
    for src in sources:
        src = Path(src)
        files = [src] if src.is_file() else sorted(p for p in src.rglob("*") if p.suffix in (".safetensors", ".pt",
                                                                                           ".bin", ".json"))
        for f in files:
            out[str(f.relative_to(src.parent) if src.is_dir() else f.name)] = sha256(f)
    return out


def versions() -> dict[str, str]:
    from importlib.metadata import PackageNotFoundError, version

    import torch

    try:
        ours = version("gesturelsm")
    except PackageNotFoundError:                       # a checkout on PYTHONPATH, not installed
        ours = "checkout"
    return dict(gesturelsm=ours, python=platform.python_version(), numpy=np.__version__,
                torch=torch.__version__, platform=sys.platform)


@dataclass
class Manifest:
    settings: dict
    checkpoints: dict[str, str]
    files: dict[str, dict]                      # sample file -> speech, its SHA-256, seed, sample number

    def write(self, out: Path) -> Path:
        path = Path(out) / MANIFEST
        body = dict(leaderboard_rules=RULES, fps=FPS, sample_rate=SAMPLE_RATE, settings=self.settings,
                    checkpoints=self.checkpoints, versions=versions(), files=dict(sorted(self.files.items())))
        tmp = path.with_suffix(".part")
        tmp.write_text(json.dumps(body, indent=1) + "\n")
        tmp.replace(path)
        return path


def refuse_all(problems: list[str]) -> None:
    if problems:
        raise InputError("the leaderboard would not accept this submission:\n" + "\n".join(problems))


__all__ = ["MANIFEST", "Manifest", "RULES", "SAMPLES", "check_arrays", "check_name", "check_speech",
           "checkpoint_hashes", "read_arrays", "refuse_all", "sample_name", "sample_seeds", "sha256", "take_of",
           "versions"]
