"""Every method the pipeline can run, ours and the authors', as a backend in one registry.

`BACKENDS` maps each method's key to its registry line: the method's facts (`base.BackendFacts`: default and
maximum steps, CFG bound, what it predicts, whether it takes a step size, which regions it generates, whether it
can hold known latents to edit a motion) and how
its checkpoint is found and loaded. `load_backends` builds the backends found in a list of checkpoint files
and folders. A new method = a backend module in this folder (or, for one of ours, a method in `flows/`)
and one line below.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, Sequence

import torch

from ..constants import ASSETS
from ..errors import CheckpointError, InputError
from ..flows import METHODS
from .authors import RVQ_FILE, Authors
from .base import MAX_CFG, Backend, BackendFacts, BackendKind, BackendOutput, Bounds, Progress, SpeechInput
from .ours import FlowBackend, Ours

BACKENDS: dict[str, BackendKind] = {b.facts.key: b for b in (
    *(Ours.of(key) for key in METHODS),                  # ours: every method of the flows registry
    Authors.of("gesturelsm_authors", "shortcut", default_steps=2, max_steps=128, predicts="velocity",
               uses_step_size=True, inpaints=True),
    Authors.of("meanflow_authors", "meanflow", default_steps=1, max_steps=128, predicts="velocity",
               uses_step_size=True),
    Authors.of("diffusion_authors", "diffusion", default_steps=20, max_steps=1000, predicts="data",
               uses_step_size=False, inpaints=True),
)}
FACTS: dict[str, BackendFacts] = {k: b.facts for k, b in BACKENDS.items()}


def backend_facts(key: str) -> BackendFacts:
    if key not in FACTS:
        raise InputError(f"unknown method {key!r}; the methods are: {', '.join(FACTS)}")
    return FACTS[key]


def _found_in(source: Path) -> list[tuple[BackendKind, Path]]:
    """(registry line, checkpoint file) of every method with a checkpoint in `source` (a folder or one file)."""
    if source.is_dir():
        return [(b, b.checkpoint(source)) for b in BACKENDS.values() if b.checkpoint(source).is_file()]
    for b in BACKENDS.values():
        if b.checkpoint(b.root_of(source)) == source:
            return [(b, source)]
    raise CheckpointError(f"{source}: not a checkpoint of any method (expected generator/<method>.safetensors "
                          f"or reference_<sampler>.safetensors; methods: {', '.join(FACTS)})")


def load_backends(checkpoints: Sequence[str | Path], methods: Iterable[str] | None = None,
                  device: str | torch.device = "cpu") -> dict[str, Backend]:
    """The backends in `checkpoints` (folders and/or files), in registry order; `methods`: only these. A folder
    with no checkpoint, a method found twice, or none of `methods` found is a CheckpointError saying so."""
    wanted = None if methods is None else set(methods)
    found: dict[str, tuple[BackendKind, Path]] = {}
    for source in map(Path, checkpoints):
        if not source.exists():
            raise CheckpointError(f"{source}: no such checkpoint file or folder")
        here = _found_in(source)
        if not here:
            raise CheckpointError(f"{source}: no checkpoints found (expected tokenizer/ and generator/<method>"
                                  f".safetensors, or {RVQ_FILE} and reference_<sampler>.safetensors written by "
                                  "`gesturelsm import-reference`)")
        for b, file in here:
            key = b.facts.key
            if key in found:
                raise CheckpointError(f"method {key} has two checkpoints: {found[key][1]} and {file}; give one")
            found[key] = (b, file)
    chosen = [k for k in BACKENDS if k in found and (wanted is None or k in wanted)]
    if not chosen:
        raise CheckpointError(f"no checkpoint for {', '.join(sorted(wanted or ()))} in "
                              f"{', '.join(map(str, checkpoints))}; found: {', '.join(found)}")
    shared: dict = {}
    return {k: found[k][0].load(found[k][1], device, shared) for k in chosen}


def checkpoint_sources(path: str | Path | None) -> list[Path]:
    """What a `--checkpoints` setting (CLI, app, environment) loads: nothing given, the shipped models; a folder
    of the authors' converted weights only (`gesturelsm import-reference --out`), those beside the shipped
    models; any other file or folder, exactly that."""
    if path is None or str(path) == "":
        return [ASSETS]
    p = Path(path)
    if p.is_dir() and (p / RVQ_FILE).is_file() and not any(Ours.of(k).checkpoint(p).is_file() for k in METHODS):
        return [ASSETS, p]
    return [p]


def flow_backends(tokenizers: dict, generators: dict) -> dict[str, Backend]:
    """Our backends from models already in memory ({method: GestureGenerator} on shared tokenizers)."""
    return {k: FlowBackend(backend_facts(k), g, tokenizers) for k, g in generators.items()}


__all__ = ["BACKENDS", "FACTS", "MAX_CFG", "Backend", "BackendFacts", "BackendKind", "BackendOutput", "Bounds",
           "FlowBackend", "Progress", "SpeechInput", "backend_facts", "checkpoint_sources", "flow_backends",
           "load_backends"]
