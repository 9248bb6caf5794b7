"""One registry for every method: backends built from checkpoint folders or files, bounds from the specs,
the authors' methods as backends like ours, clear messages for missing or unknown ones."""
from __future__ import annotations

import shutil
from dataclasses import replace

import numpy as np
import pytest

from _support import speech_like
from gesturelsm.backends import BACKENDS, MAX_CFG, SPECS, checkpoint_sources, method_spec
from gesturelsm.backends.authors import AuthorsBackend
from gesturelsm.backends.lines import Ours
from gesturelsm.backends.ours import FlowBackend
from gesturelsm.constants import ASSETS
from gesturelsm.errors import CheckpointError, InputError
from gesturelsm.flows import METHODS
from gesturelsm.pipeline import GesturePipeline


def test_registry_lists_ours_then_the_authors_methods_with_their_specs():
    assert list(SPECS) == ["gesturelsm", "rectified_flow", "ddim", "gesturelsm_authors", "meanflow_authors",
                           "diffusion_authors"]
    assert [k for k, f in SPECS.items() if f.imported] == ["gesturelsm_authors", "meanflow_authors",
                                                           "diffusion_authors"]
    assert (SPECS["gesturelsm"].default_steps, SPECS["ddim"].default_steps, SPECS["gesturelsm_authors"].default_steps,
            SPECS["meanflow_authors"].default_steps, SPECS["diffusion_authors"].default_steps) == (8, 20, 2, 1, 20)
    assert "face" in SPECS["gesturelsm"].regions and "face" not in SPECS["meanflow_authors"].regions
    assert all(BACKENDS[k].spec is f for k, f in SPECS.items())
    assert [k for k, f in SPECS.items() if f.steps_setting == "ddim_steps"] == ["ddim", "diffusion_authors"]
    # what each sampler can hold fixed while it samples the rest (an editing feature needs it)
    assert [k for k, f in SPECS.items() if not f.inpainting] == ["meanflow_authors"]
    ours = [k for k, b in BACKENDS.items() if isinstance(b, Ours)]
    assert ours == list(METHODS) and all(SPECS[k].max_steps == METHODS[k].facts.max_steps for k in ours)


def test_backend_from_an_explicit_checkpoint_file_equals_the_folders():
    """One generator file (its tokenizers found beside it) gives the same motion as the whole folder."""
    one = GesturePipeline.from_pretrained(checkpoints=[ASSETS / "generator" / "ddim.safetensors"], warm_up=False)
    assert one.methods == ["ddim"] and isinstance(one.backends["ddim"], FlowBackend)
    full = GesturePipeline.from_pretrained(ASSETS, warm_up=False)
    assert full.methods == ["gesturelsm", "rectified_flow", "ddim"]
    y = speech_like(2.0)
    a = one.generate(y, 16000, steps=2, cfg=1.5, seed=3, method="ddim", transcribe=False, output="raw").motion
    b = full.generate(y, 16000, steps=2, cfg=1.5, seed=3, method="ddim", transcribe=False, output="raw").motion
    assert np.array_equal(a.poses, b.poses) and np.array_equal(a.expressions, b.expressions)


def test_authors_methods_are_backends_without_patching(ckpt_dir):
    theirs = GesturePipeline.from_pretrained(checkpoints=[ckpt_dir], warm_up=False)
    assert theirs.methods == ["gesturelsm_authors", "meanflow_authors"]          # registry order, only what is there
    assert all(isinstance(b, AuthorsBackend) for b in theirs.backends.values())
    assert not hasattr(theirs, "reference_methods") and theirs.generators == {} and theirs.tokenizers == {}
    both = GesturePipeline.from_pretrained(checkpoints=[ASSETS, ckpt_dir / "reference_meanflow.safetensors"],
                                           warm_up=False)
    assert both.methods == ["gesturelsm", "rectified_flow", "ddim", "meanflow_authors"]
    res = both.generate(speech_like(1.0), 16000, steps=1, cfg=1.0, method="meanflow_authors", transcribe=False,
                        output="raw")
    assert res.motion.num_frames == 30 and np.allclose(res.motion.expressions, 0)


def test_bounds_come_from_the_specs():
    pipe = GesturePipeline.from_pretrained(ASSETS, warm_up=False)
    for m in pipe.methods:
        b = pipe.bounds(m)
        assert (b.min_steps, b.max_steps, b.min_cfg, b.max_cfg) == (1, SPECS[m].max_steps, 0.0, MAX_CFG)
        pipe.check_settings(m, b.max_steps, b.max_cfg)
        with pytest.raises(InputError, match=f"Steps for {SPECS[m].label} must be from 1 to {b.max_steps} "):
            pipe.check_settings(m, b.max_steps + 1, 1.0)
    backend = pipe.backends["gesturelsm"]
    backend.spec = replace(backend.spec, default_steps=2, max_steps=3, max_cfg=1.5)    # the checker reads nothing else
    with pytest.raises(InputError, match="Steps for GestureLSM must be from 1 to 3 "):
        pipe.check_settings("gesturelsm", 4, 1.0)
    with pytest.raises(InputError, match="between 0 and 1.5"):
        pipe.check_settings("gesturelsm", 2, 2.0)


def test_unknown_method_is_named_with_the_choices():
    pipe = GesturePipeline.from_pretrained(ASSETS, methods=["gesturelsm"], warm_up=False)
    with pytest.raises(InputError, match="unknown method 'meanflow_authors'; available: gesturelsm$"):
        pipe.generate(speech_like(1.0), method="meanflow_authors", output="raw")
    with pytest.raises(InputError, match="unknown method 'nope'; the methods are: gesturelsm, rectified_flow"):
        method_spec("nope")


def test_missing_checkpoints_are_said_clearly(tmp_path, ckpt_dir):
    with pytest.raises(CheckpointError, match=f"{tmp_path}: no checkpoints found"):
        GesturePipeline.from_pretrained(tmp_path, warm_up=False)               # not the shipped assets instead
    with pytest.raises(CheckpointError, match="no such checkpoint file or folder"):
        GesturePipeline.from_pretrained(tmp_path / "absent", warm_up=False)
    with pytest.raises(CheckpointError, match="not a checkpoint of any method"):
        GesturePipeline.from_pretrained(checkpoints=[ASSETS / "tokenizer" / "face.safetensors"], warm_up=False)
    with pytest.raises(CheckpointError, match="method gesturelsm has two checkpoints"):
        GesturePipeline.from_pretrained(checkpoints=[ASSETS, ASSETS / "generator" / "gesturelsm.safetensors"],
                                        warm_up=False)
    with pytest.raises(CheckpointError, match="no checkpoint for ddim in"):
        GesturePipeline.from_pretrained(ckpt_dir, methods=["ddim"], warm_up=False)
    lone = tmp_path / "lone"
    lone.mkdir()
    shutil.copy(ckpt_dir / "reference_shortcut.safetensors", lone)
    with pytest.raises(CheckpointError, match="reference_rvq.safetensors is missing beside it"):
        GesturePipeline.from_pretrained(lone, warm_up=False)
    (tmp_path / "gen" / "generator").mkdir(parents=True)
    shutil.copy(ASSETS / "generator" / "ddim.safetensors", tmp_path / "gen" / "generator")
    with pytest.raises(CheckpointError, match="missing tokenizer checkpoints for upper, hands, lower, face"):
        GesturePipeline.from_pretrained(tmp_path / "gen", warm_up=False)


def test_checkpoints_setting_puts_the_authors_beside_the_shipped_models(ckpt_dir):
    """`--checkpoints`: nothing, the shipped models; an import-reference folder, those beside them; else exactly it."""
    assert checkpoint_sources(None) == [ASSETS]
    assert checkpoint_sources(ckpt_dir) == [ASSETS, ckpt_dir]
    assert checkpoint_sources(str(ASSETS)) == [ASSETS]
    rvq = ckpt_dir / "reference_rvq.safetensors"
    assert checkpoint_sources(rvq) == [rvq]
