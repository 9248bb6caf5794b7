"""The registry's lines (`gesturelsm.backends.BACKENDS`): for one method, its spec and where its checkpoint lies in a
folder, without torch, so the command line's parsers read the methods before any model code loads. `load` imports
the backend's code (ours.py, authors.py) when a checkpoint is loaded."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import CheckpointError
from .spec import MethodSpec

if TYPE_CHECKING:
    import torch

    from .authors import AuthorsBackend
    from .ours import FlowBackend

RVQ_FILE = "reference_rvq.safetensors"     # the authors' RVQ-VAEs and statistics, shared by their methods


@dataclass(frozen=True)
class Ours:
    """Registry line of one of our methods (a sampler of the flows registry, `flows.METHODS`, under the same key)."""
    spec: MethodSpec

    def checkpoint(self, root: Path) -> Path:
        return root / "generator" / f"{self.spec.key}.safetensors"

    def root_of(self, file: Path) -> Path:
        return file.parent.parent

    def load(self, file: Path, device: str | torch.device, shared: dict) -> FlowBackend:
        from ..generator.model import GestureGenerator
        from .ours import FlowBackend, load_tokenizers

        root = self.root_of(file)
        if ("tokenizers", root) not in shared:
            shared["tokenizers", root] = load_tokenizers(root / "tokenizer", device)
        return FlowBackend(self.spec, GestureGenerator.load(file).to(device), shared["tokenizers", root])


@dataclass(frozen=True)
class Authors:
    """Registry line of one of the authors' methods: its spec (their released settings) and its sampler's file."""
    spec: MethodSpec
    sampler: str                     # "shortcut" | "meanflow" | "diffusion": reference_<sampler>.safetensors

    def checkpoint(self, root: Path) -> Path:
        return root / f"reference_{self.sampler}.safetensors"

    def root_of(self, file: Path) -> Path:
        return file.parent

    def load(self, file: Path, device: str | torch.device, shared: dict) -> AuthorsBackend:
        from ..reference.convert import load_generator, load_rvqs
        from ..reference.runner import ReferenceBundle
        from .authors import AuthorsBackend

        root = self.root_of(file)
        if ("reference", root) not in shared:
            if not (root / RVQ_FILE).exists():
                raise CheckpointError(f"{file}: {RVQ_FILE} is missing beside it (write both with "
                                      "`gesturelsm import-reference`)")
            shared["reference", root] = ReferenceBundle(*load_rvqs(root / RVQ_FILE))
        return AuthorsBackend(self.spec, shared["reference", root], *load_generator(file))


__all__ = ["Authors", "Ours", "RVQ_FILE"]
