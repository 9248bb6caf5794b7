"""What a study video is made of, and the blinded name that says so only to whoever holds the salt.

A video's settings are one flat dict: every generation setting of the `Plan` the video was made with and every
post-processing option (`gesturelsm.settings.Settings` and `PostProcess`: an option added there changes the names
without anything here changing), that method's steps, a digest of the
method's weights, and the rendering settings (size, the body model and the character, each as its file name and a
digest of its bytes). The blinded name hashes the salt, the speech file, the method and that whole dict, so a
video made with other settings never takes the name of one already there.

A study folder records the settings of its videos and its design in study.json; a run of `gesturelsm batch` into
a folder made with other settings is refused with the settings that differ (the key, conditions.csv, must describe
the videos beside it, and the raters' trials were fixed with the first design).
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, fields
from pathlib import Path
from typing import Iterator, Mapping

import torch

from ..errors import UserError
from ..pipeline import GROUND_TRUTH, Plan

SETTINGS_FILE = "study.json"
PER_VIDEO = ("methods", "steps", "transcribe", "language", "post")   # Settings fields that are not one video's (post:
                                                                       # its options are, one by one)
FLAGS = {"steps": "--steps / --ddim-steps", "cfg": "--cfg", "seed": "--seed", "smoothing": "--smoothing",
         "stand_in_place": "--stand-in-place", "grounding": "--grounding", "size": "--size", "body": "--model",
         "character": "--rig", "weights": "--checkpoints", "mode": "--design", "attention": "--attention",
         "segments": "--segments"}


def video_settings(plan: Plan, method: str, render: Mapping[str, object], weights: str | None) -> dict:
    """Everything that makes `method`'s video under `plan`: the plan's fields, the method's steps and weights
    (not for ground truth), and `render` (size, body, character)."""
    s = plan.settings
    out = {f.name: getattr(s, f.name) for f in fields(s) if f.name not in PER_VIDEO} | asdict(s.post)
    if method != GROUND_TRUTH:
        out.update(steps=plan.steps_for(method), weights=weights)
    out.update(render)
    return json.loads(json.dumps(out, sort_keys=True, default=str))      # plain JSON values, as study.json holds


def blinded_name(salt: str, audio: str, method: str, settings: Mapping[str, object] | None = None) -> str:
    text = f"{salt}|{audio}|{method}|{json.dumps(dict(settings or {}), sort_keys=True, default=str)}"
    return "v_" + hashlib.sha256(text.encode()).hexdigest()[:10] + ".mp4"


def file_label(path: Path) -> str:
    """A file's name and the first 12 hex digits of its SHA-256."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return f"{Path(path).name} {h.hexdigest()[:12]}"


def _tensors(obj, prefix: str = "", depth: int = 0) -> Iterator[tuple[str, torch.Tensor]]:
    """(name, tensor) of every tensor reachable from `obj` through modules, dicts, sequences and attributes."""
    if isinstance(obj, torch.nn.Module):
        yield from ((prefix + k, v) for k, v in sorted(obj.state_dict().items()))
        return
    if isinstance(obj, torch.Tensor):
        yield prefix, obj
        return
    if depth >= 3:
        return
    if isinstance(obj, dict):
        items = list(obj.items())
    elif isinstance(obj, (list, tuple)):
        items = list(enumerate(obj))
    elif hasattr(obj, "__dict__") and not isinstance(obj, type):
        items = list(vars(obj).items())
    else:
        return
    for k, v in sorted(items, key=lambda kv: str(kv[0])):
        yield from _tensors(v, f"{prefix}{k}.", depth + 1)


def weights_digest(backend) -> str:
    """The first 12 hex digits of a SHA-256 over every tensor a backend holds (its models' state dicts)."""
    h = hashlib.sha256()
    for name, t in _tensors(backend):
        h.update(name.encode())
        h.update(str(t.dtype).encode())
        h.update(t.detach().cpu().contiguous().reshape(-1).view(torch.uint8).numpy().tobytes())
    return h.hexdigest()[:12]


def read_settings(out: Path) -> dict:
    path = Path(out) / SETTINGS_FILE
    if not path.exists():
        return {}
    try:
        return json.loads(path.read_text())
    except ValueError:
        raise UserError(f"{path} is damaged (not JSON); it records how this study's videos were made") from None


def _differences(old: Mapping, new: Mapping, what: str) -> list[str]:
    return [f"{FLAGS.get(k, k)} {what}was {old.get(k)!r}, this run {new.get(k)!r}"
            for k in sorted(set(old) | set(new)) if old.get(k) != new.get(k)]


def check_unchanged(out: Path, videos: Mapping[str, Mapping], design: Mapping) -> None:
    """A UserError naming every setting in which this run differs from the one that made `out`'s videos and
    design (a new method is fine: its videos get their own names)."""
    out = Path(out)
    old = read_settings(out)
    if not old and not (out / "key" / "conditions.csv").exists():
        return                                          # a new study
    if "videos" not in old:
        raise UserError(f"{out} does not record how its videos were made (it was made by an earlier gesturelsm), "
                        "so they cannot be told apart from this run's; make the study in a new --out folder")
    diffs = [d for m in sorted(set(old["videos"]) & set(videos))
             for d in _differences(old["videos"][m], videos[m], f"for {m} ")]
    diffs += _differences(old.get("design", {}), design, "")
    if diffs:
        raise UserError(f"{out} was made with other settings than this run ({'; '.join(diffs)}); its key must "
                        "describe the videos beside it and its raters' trials are fixed: run with the study's "
                        "settings, or make this one in a new --out folder")


__all__ = ["SETTINGS_FILE", "blinded_name", "check_unchanged", "file_label", "read_settings", "video_settings",
           "weights_digest"]
