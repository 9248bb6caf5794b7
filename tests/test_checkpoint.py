"""checkpoint.py: safetensors files with the model kind and config in their metadata."""
from __future__ import annotations

from dataclasses import dataclass

import pytest
import torch

from gesturelsm.checkpoint import config_from_dict, load_checkpoint, save_checkpoint
from gesturelsm.errors import CheckpointError, GestureError


@dataclass(frozen=True)
class Cfg:
    width: int = 4
    regions: tuple = ("upper", "hands")


def test_round_trip_keeps_tensors_config_and_metadata(tmp_path):
    t = {"w": torch.randn(3, 4), "norm.mean": torch.randn(4), "steps": torch.arange(5)}
    path = save_checkpoint(tmp_path / "m.safetensors", t, "generator", Cfg(8), meta={"method": "ddim", "n": 3})
    tensors, meta = load_checkpoint(path, "generator")
    assert all(torch.equal(tensors[k], t[k]) for k in t)
    assert meta["kind"] == "generator" and meta["method"] == "ddim"
    assert config_from_dict(Cfg, meta["config"]) == Cfg(8)                     # tuples come back as tuples
    assert not list(tmp_path.glob("*.tmp"))                                    # written atomically


def test_half_precision_keeps_statistics_in_fp32(tmp_path):
    t = {"w": torch.randn(16), "norm.std": torch.rand(16) + 0.5}
    tensors, _ = load_checkpoint(save_checkpoint(tmp_path / "h.safetensors", t, "tokenizer", Cfg(), half=True))
    assert torch.equal(tensors["norm.std"], t["norm.std"])                      # exact
    assert torch.allclose(tensors["w"], t["w"], rtol=1e-3) and not torch.equal(tensors["w"], t["w"])


def test_unknown_config_keys_are_ignored():
    assert config_from_dict(Cfg, {"width": 2, "regions": ["a"], "gone": 1}) == Cfg(2, ("a",))


def test_wrong_or_broken_files_raise_the_error_family(tmp_path):
    path = save_checkpoint(tmp_path / "t.safetensors", {"w": torch.zeros(1)}, "tokenizer", Cfg())
    with pytest.raises(CheckpointError, match="expected 'generator'"):
        load_checkpoint(path, "generator")
    with pytest.raises(CheckpointError, match="not found"):
        load_checkpoint(tmp_path / "missing.safetensors")
    (tmp_path / "junk.safetensors").write_bytes(b"not a model")
    with pytest.raises(GestureError, match="not a readable"):
        load_checkpoint(tmp_path / "junk.safetensors")
