"""Checkpoints: safetensors weights with the model's config (JSON) in the file's metadata.

A model is rebuilt from the file alone: `kind` names the model class, `config` holds the frozen config
dataclass's fields, and any further metadata (training step, data, preset name) rides along as strings.
Shipped files store weights in fp16 (half the bytes); they are loaded back into fp32.
"""
from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import torch
from safetensors import safe_open
from safetensors.torch import save_file

from .errors import CheckpointError


def save_checkpoint(path: str | Path, tensors: dict[str, torch.Tensor], kind: str, config: Any,
                    meta: dict[str, Any] | None = None, half: bool = False) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    out = {}
    for k, v in tensors.items():
        v = v.detach().cpu().contiguous()
        if half and v.is_floating_point() and not k.startswith("norm."):  # statistics stay fp32
            v = v.half()
        out[k] = v
    metadata = {"kind": kind, "config": json.dumps(dataclasses.asdict(config))}
    for k, v in (meta or {}).items():
        metadata[k] = v if isinstance(v, str) else json.dumps(v)
    tmp = path.with_name(path.name + ".tmp")
    save_file(out, str(tmp), metadata=metadata)
    tmp.replace(path)  # never leave a half-written checkpoint behind
    return path


def load_checkpoint(path: str | Path, kind: str | None = None) -> tuple[dict[str, torch.Tensor], dict[str, Any]]:
    """-> (fp32 tensors, metadata with `config` parsed to a dict)."""
    path = Path(path)
    if not path.exists():
        raise CheckpointError(f"model file not found: {path}")
    try:
        with safe_open(str(path), framework="pt") as f:
            meta = dict(f.metadata() or {})
            tensors = {k: f.get_tensor(k) for k in f.keys()}
    except Exception as exc:
        raise CheckpointError(f"{path}: not a readable safetensors model file ({exc})") from None
    if "config" not in meta or "kind" not in meta:
        raise CheckpointError(f"{path}: no model config in the file's metadata (not a gesturelsm checkpoint)")
    if kind is not None and meta["kind"] != kind:
        raise CheckpointError(f"{path}: holds a {meta['kind']!r} model, expected {kind!r}")
    meta["config"] = json.loads(meta["config"])
    tensors = {k: (v.float() if v.is_floating_point() else v) for k, v in tensors.items()}
    return tensors, meta


def config_from_dict(cls: type, d: dict[str, Any]):
    """Build a frozen config dataclass, ignoring unknown keys and restoring tuples from JSON lists."""
    fields = {f.name: f for f in dataclasses.fields(cls)}
    kwargs = {}
    for k, v in d.items():
        if k in fields:
            kwargs[k] = tuple(v) if isinstance(v, list) else v
    return cls(**kwargs)
