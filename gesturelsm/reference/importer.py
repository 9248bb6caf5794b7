"""`import_reference(DIR, OUT)`: find the released files under DIR, convert them, write our checkpoints.

Expected (any sub-folder of DIR): shortcut_reflow.bin, new_540_diffusion.bin, meanflow.pth (each optional,
at least one), net_300000_{upper,hands,lower}.pth, vocab.pkl, and the normalisation statistics of the
reference repository's mean_std/ folder: beatx_2_330_{mean,std}.npy, beatx_2_trans_{mean,std}.npy.
Writes OUT/reference_rvq.safetensors and OUT/reference_{shortcut,meanflow,diffusion}.safetensors.
"""
from __future__ import annotations

from pathlib import Path

from .config import REGIONS
from .convert import check_region_dims, generator_from_state, rvq_from_state, save_generator, save_rvqs
from .released_files import ReferenceFileError, load_npy, load_state, load_vocab

GENERATOR_FILES = {"shortcut": "shortcut_reflow.bin", "diffusion": "new_540_diffusion.bin", "meanflow": "meanflow.pth"}
STAT_FILES = {"mean": "beatx_2_330_mean.npy", "std": "beatx_2_330_std.npy",
              "trans_mean": "beatx_2_trans_mean.npy", "trans_std": "beatx_2_trans_std.npy"}
GENERATOR_KEYS = ("model_state_dict", "model_state", "state_dict")


def _find(root: Path, name: str) -> Path | None:
    hits = sorted(root.rglob(name))
    return hits[0] if hits else None


def _require(root: Path, name: str, hint: str) -> Path:
    p = _find(root, name)
    if p is None:
        raise ReferenceFileError(f"{name} not found under {root} ({hint})")
    return p


def import_reference(src: str | Path, out: str | Path, heads: int = 4) -> list[Path]:
    src, out = Path(src), Path(out)
    if not src.is_dir():
        raise ReferenceFileError(f"not a folder: {src}")
    gens = {m: p for m, f in GENERATOR_FILES.items() if (p := _find(src, f)) is not None}
    if not gens:
        raise ReferenceFileError(f"no released generator under {src}: expected one of "
                                 f"{sorted(GENERATOR_FILES.values())}")
    hint = "from the authors' release: Google Drive / huggingface.co/pliu23/GestureLSM"
    rvqs = {r: rvq_from_state(load_state(_require(src, f"net_300000_{r}.pth", hint), ("net",))) for r in REGIONS}
    check_region_dims(rvqs)
    stats = {k: load_npy(_require(src, f, "the reference repository's mean_std/ folder"))
             for k, f in STAT_FILES.items()}
    if stats["mean"].shape != (330,) or stats["trans_mean"].shape != (3,):
        raise ReferenceFileError("statistics must be 330 (6D pose) and 3 (translation velocity) values")
    w2i, _ = load_vocab(_require(src, "vocab.pkl", "weights/vocab.pkl of the release"))
    written = [save_rvqs(out / "reference_rvq.safetensors", rvqs, stats, "net_300000_{upper,hands,lower}.pth")]
    for method, path in gens.items():
        model = generator_from_state(load_state(path, GENERATOR_KEYS), method, heads)
        if max(w2i.values(), default=0) >= model.cfg.vocab_size:
            raise ReferenceFileError(f"vocab.pkl has indices beyond the {model.cfg.vocab_size} embeddings of "
                                     f"{path.name}")
        written.append(save_generator(out / f"reference_{method}.safetensors", model, w2i, path.name))
    return written
