"""Operator-supplied files: checkpoints load as tensors only, SMPL-X .npz files read their
pickled members through an allow-list; a pickle that would run code is refused and the code never runs."""
from __future__ import annotations

import os

import numpy as np
import pytest
import torch

from gesturelsm.safe_load import UnsafePickleError, load_npz, load_tensors


class _RunsCode:
    """Unpickling this creates the file named in `marker` (a stand-in for any command)."""

    def __init__(self, marker: str):
        self.marker = marker

    def __reduce__(self):
        return (os.mknod, (self.marker,))


def test_checkpoint_with_code_is_refused_and_nothing_runs(tmp_path):
    marker = tmp_path / "ran"
    torch.save({"model": {"w": torch.ones(2)}, "step": 3, "x": _RunsCode(str(marker))}, tmp_path / "evil.pt")
    with pytest.raises(ValueError, match="refused to load.*could run code"):
        load_tensors(tmp_path / "evil.pt")
    assert not marker.exists()
    torch.save({"model": {"w": torch.ones(2)}, "step": 3, "rng": torch.get_rng_state()}, tmp_path / "ok.pt")
    st = load_tensors(tmp_path / "ok.pt")
    assert st["step"] == 3 and torch.equal(st["model"]["w"], torch.ones(2))


@pytest.mark.parametrize("module", ["gesturelsm.generator.train", "gesturelsm.tokenizer.train",
                                    "gesturelsm.metrics.emage_fgd"])
def test_no_checkpoint_loader_allows_arbitrary_pickles(module):
    import importlib
    import inspect

    src = inspect.getsource(importlib.import_module(module))
    assert "weights_only=False" not in src and "load_tensors(" in src


def test_emage_weights_with_code_are_refused(tmp_path):
    from gesturelsm.metrics.emage_fgd import SkeletonConvEncoder, load_emage_weights

    marker = tmp_path / "ran"
    torch.save({"model_state": {"encoder.x": torch.zeros(1)}, "cfg": _RunsCode(str(marker))}, tmp_path / "ae.bin")
    with pytest.raises(ValueError, match="refused to load"):
        load_emage_weights(SkeletonConvEncoder(), tmp_path / "ae.bin")
    assert not marker.exists()


def test_npz_object_members_plain_data_only(tmp_path):
    np.savez(tmp_path / "ok.npz", a=np.arange(3), joint2num=np.array({"pelvis": 0, "head": 15}, dtype=object),
             names=np.array(["a", "b"], dtype=object))
    d = load_npz(tmp_path / "ok.npz")
    assert d["joint2num"].item() == {"pelvis": 0, "head": 15} and list(d["names"]) == ["a", "b"]
    marker = tmp_path / "ran"
    np.savez(tmp_path / "evil.npz", a=np.arange(3), x=np.array([_RunsCode(str(marker))], dtype=object))
    with pytest.raises(UnsafePickleError, match="posix.mknod"):
        load_npz(tmp_path / "evil.npz")
    assert not marker.exists()


def test_smplx_model_file_with_code_is_refused_before_smplx_reads_it(tmp_path):
    """The mannequin file plus one malicious member: smplx would np.load it with allow_pickle=True."""
    from gesturelsm.body import load_body_model
    from gesturelsm.body.model import resolve_model_path
    from gesturelsm.body.model_file import BodyModelError

    with np.load(resolve_model_path(None)) as data:
        members = {k: data[k] for k in data.files}
    marker = tmp_path / "ran"
    np.savez(tmp_path / "SMPLX_NEUTRAL_2020.npz", **members, joint2num=np.array([_RunsCode(str(marker))], dtype=object))
    with pytest.raises(BodyModelError, match="refusing to load it"):
        load_body_model(tmp_path / "SMPLX_NEUTRAL_2020.npz")
    assert not marker.exists()
    np.savez(tmp_path / "plain.npz", **members, joint2num=np.array({"pelvis": 0}, dtype=object))
    assert load_body_model(tmp_path / "plain.npz").num_vertices == members["v_template"].shape[0]
