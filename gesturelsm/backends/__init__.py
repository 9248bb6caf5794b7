"""Every method the pipeline can run, ours and the authors', as a backend in one registry.

`BACKENDS` maps each method's key to its registry line: the method's spec (`spec.MethodSpec`: label, colour, default
and maximum steps, which step setting drives it, CFG bound, regions, whether it can inpaint) and how its checkpoint
is found and loaded. `SPECS` reads the specs from it (a live view: a line added to `BACKENDS` is seen everywhere),
`load_backends` builds the backends found in a list of checkpoint files and folders. A new method = a backend module
in this folder (or, for one of ours, a sampler in `flows/`) and one line below. The registry loads no torch (its
lines, lines.py, import a backend's code when they load it): the command line's parsers list the methods without it.
"""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Iterable, Iterator, Mapping, Sequence

from ..constants import ASSETS, Progress
from ..errors import CheckpointError, InputError
from ..flows.facts import DDIM_FACTS, RECTIFIED_FLOW_FACTS, SHORTCUT_FACTS
from ..lazy import lazy_names
from ..reference.config import REGIONS as AUTHORS_REGIONS
from .lines import RVQ_FILE, Authors, Ours
from .spec import GROUND_TRUTH, GROUND_TRUTH_LABEL, MAX_CFG, STEPS_SETTINGS, Bounds, MethodSpec

if TYPE_CHECKING:
    import torch

    from .base import Backend, BackendKind, BackendOutput, SpeechInput
    from .ours import FlowBackend

# the backends' code (torch), imported on first use: the registry itself (BACKENDS, SPECS) loads no torch
_HOME = {"Backend": "base", "BackendKind": "base", "BackendOutput": "base", "SpeechInput": "base",
         "FlowBackend": "ours"}

# Inpainting (holding known latents while sampling the rest): every sampler that visits intermediate times of a
# known forward process can. Ours: flows.base.inpainting (the live mode holds its seed with it). The authors'
# shortcut and diffusion samplers walk the same straight path / DDIM schedule. MeanFlow's default is one step from
# pure noise, where the known part carries no information.
BACKENDS: dict[str, BackendKind] = {b.spec.key: b for b in (
    Ours(MethodSpec("gesturelsm", "GestureLSM", "#d62728", 8, SHORTCUT_FACTS.max_steps, inpainting=True)),
    Ours(MethodSpec("rectified_flow", "Rectified flow", "#1f77b4", 8, RECTIFIED_FLOW_FACTS.max_steps, inpainting=True)),
    Ours(MethodSpec("ddim", "DDIM", "#2ca02c", 20, DDIM_FACTS.max_steps, "ddim_steps", inpainting=True)),
    Authors(MethodSpec("gesturelsm_authors", "GestureLSM (authors' weights)", "#9467bd", 2, 128,
                       regions=AUTHORS_REGIONS, imported=True, inpainting=True), "shortcut"),
    Authors(MethodSpec("meanflow_authors", "MeanFlow (authors' weights)", "#8c564b", 1, 128,
                       regions=AUTHORS_REGIONS, imported=True), "meanflow"),
    Authors(MethodSpec("diffusion_authors", "Diffusion (authors' weights)", "#e377c2", 20, 1000, "ddim_steps",
                       regions=AUTHORS_REGIONS, imported=True, inpainting=True), "diffusion"),
)}


class _Specs(Mapping[str, MethodSpec]):
    """{method key: spec} in registry order, read from BACKENDS at each use."""

    def __getitem__(self, key: str) -> MethodSpec:
        return BACKENDS[key].spec

    def __iter__(self) -> Iterator[str]:
        return iter(list(BACKENDS))

    def __len__(self) -> int:
        return len(BACKENDS)


SPECS: Mapping[str, MethodSpec] = _Specs()


def method_spec(key: str) -> MethodSpec:
    if key not in BACKENDS:
        raise InputError(f"unknown method {key!r}; the methods are: {', '.join(BACKENDS)}")
    return BACKENDS[key].spec


def label(key: str) -> str:
    """A method's label for people (ground truth's too); a key that is no method is shown as it is."""
    if key == GROUND_TRUTH:
        return GROUND_TRUTH_LABEL
    return BACKENDS[key].spec.label if key in BACKENDS else key


def color(key: str, fallback: str | None = None) -> str | None:
    """A method's plot colour (`fallback` for a key that is no method)."""
    return BACKENDS[key].spec.color if key in BACKENDS else fallback


def ours_default() -> list[str]:
    """The methods shown when none are chosen: every method trained here (not imported), in registry order."""
    return [k for k, b in BACKENDS.items() if not b.spec.imported]


def _found_in(source: Path) -> list[tuple[BackendKind, Path]]:
    """(registry line, checkpoint file) of every method with a checkpoint in `source` (a folder or one file)."""
    if source.is_dir():
        return [(b, b.checkpoint(source)) for b in BACKENDS.values() if b.checkpoint(source).is_file()]
    for b in BACKENDS.values():
        if b.checkpoint(b.root_of(source)) == source:
            return [(b, source)]
    raise CheckpointError(f"{source}: not a checkpoint of any method (expected generator/<method>.safetensors "
                          f"or reference_<sampler>.safetensors; methods: {', '.join(BACKENDS)})")


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
            key = b.spec.key
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
    ours = [b for b in BACKENDS.values() if isinstance(b, Ours)]
    if p.is_dir() and (p / RVQ_FILE).is_file() and not any(b.checkpoint(p).is_file() for b in ours):
        return [ASSETS, p]
    return [p]


def flow_backends(tokenizers: dict, generators: dict) -> dict[str, Backend]:
    """Our backends from models already in memory ({method: GestureGenerator} on shared tokenizers)."""
    from .ours import FlowBackend

    return {k: FlowBackend(method_spec(k), g, tokenizers) for k, g in generators.items()}


__getattr__ = lazy_names(__name__, _HOME)


__all__ = ["BACKENDS", "GROUND_TRUTH", "GROUND_TRUTH_LABEL", "MAX_CFG", "SPECS", "STEPS_SETTINGS", "Backend",
           "BackendKind", "BackendOutput", "Bounds", "FlowBackend", "MethodSpec", "Progress", "SpeechInput",
           "checkpoint_sources", "color", "flow_backends", "label", "load_backends", "method_spec", "ours_default"]
