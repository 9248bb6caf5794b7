"""The importer: released-layout files -> our checkpoints, safely; refusals; full-size shapes."""
from __future__ import annotations

import os
import pickle
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch

from gesturelsm.cli import main as cli_main
from gesturelsm.reference.config import GeneratorConfig, RVQConfig
from gesturelsm.reference.convert import generator_from_state, load_generator, load_rvqs, rvq_from_state
from gesturelsm.reference.denoiser import rope_inv_freq
from gesturelsm.reference.model import ReferenceGenerator
from gesturelsm.reference.rvq import ReferenceRVQ
from gesturelsm.reference.released_files import ReferenceFileError, load_state, load_vocab

FIX = Path(__file__).parent / "fixtures"


def _release_dir(tmp: Path) -> Path:
    d = tmp / "release"
    (d / "ckpt").mkdir(parents=True)
    (d / "mean_std").mkdir()
    (d / "weights").mkdir()
    shutil.copy(FIX / "generator.bin", d / "ckpt" / "shortcut_reflow.bin")
    shutil.copy(FIX / "generator.bin", d / "ckpt" / "meanflow.pth")
    for r in ("upper", "hands", "lower"):
        shutil.copy(FIX / f"net_300000_{r}.pth", d / "ckpt" / f"net_300000_{r}.pth")
    shutil.copy(FIX / "vocab.pkl", d / "weights" / "vocab.pkl")
    rng = np.random.default_rng(0)
    np.save(d / "mean_std" / "beatx_2_330_mean.npy", rng.normal(size=330))
    np.save(d / "mean_std" / "beatx_2_330_std.npy", rng.uniform(0.5, 1, 330))
    np.save(d / "mean_std" / "beatx_2_trans_mean.npy", np.zeros(3))
    np.save(d / "mean_std" / "beatx_2_trans_std.npy", np.ones(3))
    return d


def test_cli_import_writes_checkpoints_that_load(tmp_path, capsys):
    src = _release_dir(tmp_path)
    assert cli_main(["import-reference", str(src), "--out", str(tmp_path / "ckpt")]) == 0
    names = sorted(p.name for p in (tmp_path / "ckpt").iterdir())
    assert names == ["reference_meanflow.safetensors", "reference_rvq.safetensors", "reference_shortcut.safetensors"]
    g, w2i = load_generator(tmp_path / "ckpt" / "reference_meanflow.safetensors")
    assert (g.cfg.method, g.cfg.steps, g.cfg.cfg_scale) == ("meanflow", 1, 1.0) and w2i["hello"] == 4
    rvqs, stats = load_rvqs(tmp_path / "ckpt" / "reference_rvq.safetensors")
    assert np.allclose(stats["mean"].numpy(), np.load(src / "mean_std" / "beatx_2_330_mean.npy"))


def test_cli_missing_files_is_one_clear_line(tmp_path, capsys):
    src = _release_dir(tmp_path)
    os.remove(src / "ckpt" / "net_300000_hands.pth")
    assert cli_main(["import-reference", str(src), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "net_300000_hands.pth not found" in err and "Traceback" not in err


class _Evil:
    def __reduce__(self):
        return (os.system, ("touch /tmp/gesturelsm_pwned_marker",))


def test_vocab_pickle_with_code_is_refused_without_running_it(tmp_path):
    marker = Path("/tmp/gesturelsm_pwned_marker")
    marker.unlink(missing_ok=True)
    p = tmp_path / "vocab.pkl"
    p.write_bytes(pickle.dumps({"word2index": _Evil()}))
    with pytest.raises(ReferenceFileError, match="not allowed"):
        load_vocab(p)
    assert not marker.exists()
    p.write_bytes(pickle.dumps(eval))   # a bare builtin reference is refused as well
    with pytest.raises(ReferenceFileError, match="refused"):
        load_vocab(p)


def test_checkpoint_with_code_is_refused_without_running_it(tmp_path):
    marker = Path("/tmp/gesturelsm_pwned_marker")
    marker.unlink(missing_ok=True)
    p = tmp_path / "shortcut_reflow.bin"
    torch.save({"model_state": {"w": torch.zeros(1)}, "extra": _Evil()}, p)
    with pytest.raises(ReferenceFileError, match="refused"):
        load_state(p, ("model_state",))
    assert not marker.exists()


def test_unknown_weight_names_are_refused():
    state = load_state(FIX / "generator.bin", ("model_state",))
    state["denoiser.something_new.weight"] = torch.zeros(1)
    with pytest.raises(ReferenceFileError, match="unexpected weight"):
        generator_from_state(state, "shortcut")


ROTARY_BUFFERS = ["denoiser.rel_pos.inv_freq", "denoiser.mytimmblocks.1.spatial_temporal_attn.temporal_pos.inv_freq",
                  "denoiser.mytimmblocks.0.spatial_temporal_attn.spatial_pos.inv_freq"]


@pytest.mark.parametrize("key", ROTARY_BUFFERS)
def test_a_tampered_rotary_buffer_is_refused_naming_it(key):
    """The converter drops the rotary `inv_freq` buffers and recomputes them: the recorded file's agree (it
    converts), and a file where one differs is refused with a message that names the tensor."""
    state = load_state(FIX / "generator.bin", ("model_state",))
    assert key in state
    generator_from_state(dict(state), "shortcut")
    state[key] = state[key] * 1.01
    with pytest.raises(ReferenceFileError) as err:
        generator_from_state(state, "shortcut")
    assert key in str(err.value) and "\n" not in str(err.value)


def test_a_rotary_buffer_of_another_width_is_refused():
    state = load_state(FIX / "generator.bin", ("model_state",))
    state["denoiser.rel_pos.inv_freq"] = rope_inv_freq(2 * state["denoiser.rel_pos.inv_freq"].numel() + 2)
    with pytest.raises(ReferenceFileError, match="denoiser.rel_pos.inv_freq"):
        generator_from_state(state, "shortcut")


def _to_reference_names(ours: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
    """Invert the converter's renames for a full-size, reference-shaped state dict (plus its unused entries)."""
    inv = {"speech.wav.{}.a.conv.": "modality_encoder.WavEncoder.feat_extractor.{}.conv1.",
           "speech.wav.{}.a.bn.": "modality_encoder.WavEncoder.feat_extractor.{}.bn1.",
           "speech.wav.{}.b.conv.": "modality_encoder.WavEncoder.feat_extractor.{}.conv2.",
           "speech.wav.{}.b.bn.": "modality_encoder.WavEncoder.feat_extractor.{}.bn2.",
           "speech.wav.{}.down.conv.": "modality_encoder.WavEncoder.feat_extractor.{}.downsample.0.",
           "speech.wav.{}.down.bn.": "modality_encoder.WavEncoder.feat_extractor.{}.downsample.1."}
    flat = {"speech.word_embedding.": "modality_encoder.text_pre_encoder_body.",
            "speech.word_proj.": "modality_encoder.text_encoder_body.",
            "speech.mix.": "modality_encoder.mix_audio_text.",
            "denoiser.time_in.": "denoiser.time_embedding.linear_1.",
            "denoiser.time_out.": "denoiser.time_embedding.linear_2.",
            "denoiser.step_proj.": "denoiser.time_embedding.cond_proj.", "denoiser.seed_proj.": "denoiser.embed_text.",
            "denoiser.token_in.": "denoiser.input_process.poseEmbedding.",
            "denoiser.token_fuse.": "denoiser.input_process2.",
            "denoiser.token_out.": "denoiser.output_process.poseFinal.",
            "denoiser.null_cond": "denoiser.null_cond_embed"}
    out = {}
    for k, v in ours.items():
        parts = k.split(".")
        if k.startswith("speech.wav."):
            pre = ".".join(parts[:2] + ["{}"] + parts[3:-1]) + "."
            nk = inv[pre].format(parts[2]) + parts[-1]
        elif k.startswith("denoiser.cross."):
            i, rest = parts[2], ".".join(parts[3:])
            sub = "cross_attn." if parts[3] in ("q", "kv", "proj") else "mlp." if parts[3] in ("fc1", "fc2") else ""
            nk = f"denoiser.cross_attn_blocks.{i}.{sub}{rest}"
        elif k.startswith("denoiser.blocks."):
            i, rest = parts[2], ".".join(parts[3:])
            rest = (rest.replace("norm_attn", "norm2").replace("norm_ff", "norm3")
                    .replace("temporal.", "spatial_temporal_attn.temporal_attention.")
                    .replace("spatial.", "spatial_temporal_attn.spatial_attention."))
            rest = "mlp." + rest if parts[3] in ("fc1", "fc2") else rest
            nk = f"denoiser.mytimmblocks.{i}.{rest}"
        else:
            nk = next(r + k[len(o):] for o, r in flat.items() if k.startswith(o))
        out["module." + nk] = v
    C = ours["denoiser.token_in.weight"].shape[0]
    out["module.denoiser.sequence_pos_encoder.pe"] = torch.zeros(5000, 1, C)        # unused entries of the release
    out["module.denoiser.rel_pos.inv_freq"] = rope_inv_freq(C)                        # as the release holds it
    out["module.denoiser.embed_timestep.time_embed.0.weight"] = torch.zeros(C, C)
    out["module.denoiser.mytimmblocks.0.norm1.weight"] = torch.ones(C)
    return out


def test_full_size_release_converts_and_runs(tmp_path):
    """Paper-size, reference-shaped random files: convert with the released key names, run one window."""
    torch.manual_seed(0)
    full = ReferenceGenerator(GeneratorConfig())
    torch.save({"model_state": _to_reference_names(full.state_dict()), "epoch": 1}, tmp_path / "shortcut_reflow.bin")
    g = generator_from_state(load_state(tmp_path / "shortcut_reflow.bin", ("model_state",)), "shortcut")
    assert g.cfg == GeneratorConfig()
    n_params = sum(p.numel() for p in g.denoiser.parameters())
    assert 30e6 < n_params < 31.5e6          # the authors' paper-size denoiser has about 30.6M parameters
    audio = torch.rand(1, 533 * 128, 2)
    words = torch.randint(0, 11195, (1, 128))
    lat = g.sample(audio, words, torch.randn(1, 4, 384), torch.randn(1, 384, 32), steps=1)
    assert lat.shape == (1, 384, 32) and torch.isfinite(lat).all()
    rvq = ReferenceRVQ(RVQConfig(input_dim=180))
    sd = {k: v for k, v in rvq.state_dict().items() if k != "codes"}
    for q in range(6):
        sd[f"quantizer.layers.{q}.codebook"] = torch.randn(1024, 128)
        sd[f"quantizer.layers.{q}.embedding_proj.weight"] = torch.eye(128)
        sd[f"quantizer.layers.{q}.embedding_proj.bias"] = torch.zeros(128)
    torch.save({"net": sd}, tmp_path / "net_300000_hands.pth")
    m = rvq_from_state(load_state(tmp_path / "net_300000_hands.pth", ("net",)))
    assert m.cfg == RVQConfig(input_dim=180)
    with torch.no_grad():
        assert m.decode(m.encode(torch.randn(1, 128, 180))).shape == (1, 128, 180)
