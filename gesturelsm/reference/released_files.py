"""Reading the released files without executing anything they contain.

Tensors: `gesturelsm.safe_load.load_tensors` (torch's weights_only allow-list: tensors, dicts, lists, numbers,
strings). Vocabulary pickle (any protocol, 0-5): `gesturelsm.safe_load.PlainDataUnpickler`, which builds only numpy
arrays, plain containers, bytes (`_codecs.encode`, how protocols 0-2 store them) and the reference's `Vocab` class
(as an inert attribute bag, also through `copyreg._reconstructor`, how protocols 0-1 store an instance); any other
global (os.system,
builtins.eval, ...) is refused before it is called.
"""
from __future__ import annotations

import io
import pickle
from pathlib import Path

import numpy as np
import torch

from ..errors import CheckpointError
from ..safe_load import PlainDataUnpickler, load_tensors


class ReferenceFileError(CheckpointError):
    """A released file that cannot be read safely or is not what it should be; the message says which."""


VOCAB_CLASS_MODULES = {"dataloaders.build_vocab", "models.utils.build_vocab", "utils.build_vocab", "build_vocab",
                       "__main__"}


class VocabRecord:
    """What a pickled Vocab becomes: its attributes, nothing callable."""

    def __setstate__(self, state: dict) -> None:
        if not isinstance(state, dict):
            raise pickle.UnpicklingError("Vocab state is not a dict")
        self.__dict__.update(state)


def load_vocab(path: str | Path) -> tuple[dict[str, int], np.ndarray | None]:
    """-> (word2index, initial 300-d embedding or None) from the reference's vocab.pkl."""
    path = Path(path)
    try:
        stand_ins = {(module, "Vocab"): VocabRecord for module in VOCAB_CLASS_MODULES}
        obj = PlainDataUnpickler(io.BytesIO(path.read_bytes()), stand_ins).load()
    except FileNotFoundError:
        raise ReferenceFileError(f"vocabulary file not found: {path}") from None
    except Exception as exc:  # any failure of an untrusted file is a refusal
        raise ReferenceFileError(f"{path}: refused: not a plain vocabulary pickle ({exc})") from None
    w2i = getattr(obj, "word2index", None)
    if not isinstance(w2i, dict) or not all(isinstance(k, str) and isinstance(v, int) for k, v in w2i.items()):
        raise ReferenceFileError(f"{path}: no word2index (str -> int) in the vocabulary")
    emb = getattr(obj, "word_embedding_weights", None)
    return w2i, (np.asarray(emb, dtype=np.float32) if isinstance(emb, np.ndarray) else None)


def load_state(path: str | Path, keys: tuple[str, ...]) -> dict[str, torch.Tensor]:
    """torch.load(weights_only=True), then the first of `keys` present (e.g. 'net', 'model_state');
    DataParallel's 'module.' prefix is removed."""
    path = Path(path)
    if not path.exists():
        raise ReferenceFileError(f"file not found: {path}")
    try:
        obj = load_tensors(path)
    except Exception as exc:
        why = str(exc).splitlines()[0]
        raise ReferenceFileError(f"{path}: refused: needs more than tensors to load ({why})") from None
    if isinstance(obj, dict):
        for k in keys:
            if isinstance(obj.get(k), dict):
                obj = obj[k]
                break
    if not isinstance(obj, dict) or not all(isinstance(v, torch.Tensor) for v in obj.values()):
        raise ReferenceFileError(f"{path}: no state dict under any of {list(keys)}")
    return {(k[7:] if k.startswith("module.") else k): v for k, v in obj.items()}


def load_npy(path: str | Path) -> np.ndarray:
    try:
        return np.load(str(path), allow_pickle=False).astype(np.float32)
    except FileNotFoundError:
        raise ReferenceFileError(f"statistics file not found: {path}") from None
    except ValueError as exc:
        raise ReferenceFileError(f"{path}: refused ({exc})") from None
