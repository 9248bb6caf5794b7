"""Released files -> our modules and safetensors checkpoints (config, sampler settings, statistics inside).

Sizes are read from the weights' shapes (so reduced-size test files convert with the same code);
only the head count is not in the weights (4 in every released config).
"""
from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path
from typing import Callable

import numpy as np
import torch

from ..checkpoint import config_from_dict, load_checkpoint, save_checkpoint
from ..kernels import accelerate
from .config import REGION_DIMS, REGIONS, RELEASED_SAMPLERS, GeneratorConfig, RVQConfig
from .denoiser import rope_inv_freq
from .model import ReferenceGenerator
from .rvq import ReferenceRVQ
from .released_files import ReferenceFileError

# reference key (without 'module.') -> ours; None = not used at inference (dropped)
_RENAMES: tuple[tuple[str, str | None], ...] = (
    (r"modality_encoder\.WavEncoder\.feat_extractor\.(\d+)\.conv1\.", r"speech.wav.\1.a.conv."),
    (r"modality_encoder\.WavEncoder\.feat_extractor\.(\d+)\.bn1\.", r"speech.wav.\1.a.bn."),
    (r"modality_encoder\.WavEncoder\.feat_extractor\.(\d+)\.conv2\.", r"speech.wav.\1.b.conv."),
    (r"modality_encoder\.WavEncoder\.feat_extractor\.(\d+)\.bn2\.", r"speech.wav.\1.b.bn."),
    (r"modality_encoder\.WavEncoder\.feat_extractor\.(\d+)\.downsample\.0\.", r"speech.wav.\1.down.conv."),
    (r"modality_encoder\.WavEncoder\.feat_extractor\.(\d+)\.downsample\.1\.", r"speech.wav.\1.down.bn."),
    (r"modality_encoder\.text_pre_encoder_body\.", "speech.word_embedding."),
    (r"modality_encoder\.text_encoder_body\.", "speech.word_proj."),
    (r"modality_encoder\.mix_audio_text\.", "speech.mix."),
    (r"modality_encoder\.(audio_encoder|audio_projection)\..*", None),   # WavLM parts, unused (raw_audio off)
    (r"denoiser\.time_embedding\.linear_1\.", "denoiser.time_in."),
    (r"denoiser\.time_embedding\.linear_2\.", "denoiser.time_out."),
    (r"denoiser\.time_embedding\.cond_proj\.", "denoiser.step_proj."),
    (r"denoiser\.embed_text\.", "denoiser.seed_proj."),
    (r"denoiser\.input_process\.poseEmbedding\.", "denoiser.token_in."),
    (r"denoiser\.input_process2\.", "denoiser.token_fuse."),
    (r"denoiser\.cross_attn_blocks\.(\d+)\.cross_attn\.", r"denoiser.cross.\1."),
    (r"denoiser\.cross_attn_blocks\.(\d+)\.mlp\.", r"denoiser.cross.\1."),
    (r"denoiser\.cross_attn_blocks\.(\d+)\.", r"denoiser.cross.\1."),
    (r"denoiser\.mytimmblocks\.(\d+)\.norm1\..*", None),                  # built but never called
    (r"denoiser\.mytimmblocks\.(\d+)\.norm2\.", r"denoiser.blocks.\1.norm_attn."),
    (r"denoiser\.mytimmblocks\.(\d+)\.norm3\.", r"denoiser.blocks.\1.norm_ff."),
    # rotary frequencies per head inside each spatial-temporal attention: recomputed, checked (_check_rotary)
    (r"denoiser\.mytimmblocks\.(\d+)\.spatial_temporal_attn\.(temporal|spatial)_pos\.inv_freq$", None),
    (r"denoiser\.mytimmblocks\.(\d+)\.spatial_temporal_attn\.temporal_attention\.", r"denoiser.blocks.\1.temporal."),
    (r"denoiser\.mytimmblocks\.(\d+)\.spatial_temporal_attn\.spatial_attention\.", r"denoiser.blocks.\1.spatial."),
    (r"denoiser\.mytimmblocks\.(\d+)\.mlp\.", r"denoiser.blocks.\1."),
    (r"denoiser\.output_process\.poseFinal\.", "denoiser.token_out."),
    (r"denoiser\.null_cond_embed$", "denoiser.null_cond"),
    # rotary frequencies over frames per region, applied to the tokens before the cross-attention: recomputed by the
    # port (denoiser.rope_inv_freq), checked against the file (_check_rotary)
    (r"denoiser\.rel_pos\.inv_freq$", None),
    # a sinusoid table and a timestep MLP that the forward pass never calls (its time embedding is time_embedding)
    (r"denoiser\.(sequence_pos_encoder|embed_timestep)\..*", None),
)

# reference buffers the forward pass reads but the port recomputes: key pattern -> rotary width (C = latent width)
_ROTARY: tuple[tuple[str, Callable[[int, int], int]], ...] = (
    (r"denoiser\.rel_pos\.inv_freq", lambda C, heads: C),
    (r"denoiser\.mytimmblocks\.\d+\.spatial_temporal_attn\.(temporal|spatial)_pos\.inv_freq",
     lambda C, heads: C // heads),
)


def _check_rotary(state: dict[str, torch.Tensor], heads: int) -> None:
    """Refuse a file whose rotary `inv_freq` buffers are not the frequencies the port computes: they are dropped on
    conversion, so a file that differs there would otherwise give other motion than its authors' code."""
    width = state.get("denoiser.input_process.poseEmbedding.weight")
    if width is None:
        return                                  # not a generator of the known layout: refused by the renaming
    C = width.shape[0]
    for key, v in state.items():
        for pat, dim in _ROTARY:
            if re.fullmatch(pat, key):
                want = rope_inv_freq(dim(C, heads))
                if v.shape != want.shape or not torch.allclose(v.float(), want, rtol=1e-5, atol=1e-8):
                    raise ReferenceFileError(f"{key} is not the rotary frequencies 10000**(-2i/{dim(C, heads)}) "
                                             "that the conversion recomputes: refusing the file")


def rename_generator_keys(state: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
    out = {}
    for k, v in state.items():
        for pat, rep in _RENAMES:
            if re.match(pat, k):
                if rep is not None:
                    out[re.sub(pat, rep, k)] = v
                break
        else:
            raise ReferenceFileError(f"unexpected weight {k!r}: not a GestureLSM generator of the known layout")
    return out


def generator_config(state: dict[str, torch.Tensor], method: str, heads: int = 4) -> GeneratorConfig:
    """Read sizes from our-named weights."""
    try:
        C, cin = state["denoiser.token_in.weight"].shape
        rc = state["denoiser.null_cond"].shape
        return GeneratorConfig(
            input_dim=cin, latent_dim=C, ff_size=state["denoiser.blocks.0.fc1.weight"].shape[0],
            num_layers=len({k.split(".")[2] for k in state if k.startswith("denoiser.blocks.")}),
            num_cross=len({k.split(".")[2] for k in state if k.startswith("denoiser.cross.")}),
            num_heads=heads, regions=rc[1] // C, seq_len=rc[0],
            seed_frames=state["denoiser.seed_proj.weight"].shape[1] // (cin * (rc[1] // C)),
            audio_dim=state["speech.word_proj.weight"].shape[0],
            vocab_size=state["speech.word_embedding.weight"].shape[0],
            word_dim=state["speech.word_embedding.weight"].shape[1], frames=4 * rc[0],
            method=method, **RELEASED_SAMPLERS[method])
    except KeyError as exc:
        raise ReferenceFileError(f"generator weights lack {exc}") from None


def generator_from_state(state: dict[str, torch.Tensor], method: str, heads: int = 4) -> ReferenceGenerator:
    """A released generator state dict (DataParallel prefix already removed) -> our module, eval mode."""
    _check_rotary(state, heads)
    ours = rename_generator_keys(state)
    model = ReferenceGenerator(generator_config(ours, method, heads))
    try:
        model.load_state_dict(ours, strict=True)
    except RuntimeError as exc:
        raise ReferenceFileError(f"generator weights do not fit the reference layout: {str(exc)[:300]}") from None
    return model.eval()


def rvq_from_state(state: dict[str, torch.Tensor]) -> ReferenceRVQ:
    """A released RVQ-VAE state dict ('net') -> our module with the projected codebooks, eval mode."""
    try:
        qs = sorted({int(k.split(".")[2]) for k in state if k.startswith("quantizer.layers.")})
        cb = state["quantizer.layers.0.codebook"]
        cfg = RVQConfig(input_dim=state["encoder.model.0.weight"].shape[1],
                        width=state["encoder.model.0.weight"].shape[0],
                        code_dim=cb.shape[1], num_codes=cb.shape[0], num_quantizers=len(qs),
                        down=sum(1 for k in state if re.fullmatch(r"encoder\.model\.\d+\.0\.weight", k)))
        layer = "quantizer.layers.{}.".format
        codes = torch.stack([torch.nn.functional.linear(state[layer(q) + "codebook"],
                                                        state[layer(q) + "embedding_proj.weight"],
                                                        state[layer(q) + "embedding_proj.bias"]) for q in qs])
    except KeyError as exc:
        raise ReferenceFileError(f"RVQ-VAE weights lack {exc}") from None
    model = ReferenceRVQ(cfg)
    ours = {k: v for k, v in state.items() if not k.startswith("quantizer.")}
    ours["codes"] = codes
    try:
        model.load_state_dict(ours, strict=True)
    except RuntimeError as exc:
        raise ReferenceFileError(f"RVQ-VAE weights do not fit the reference layout: {str(exc)[:300]}") from None
    return model.eval()


def save_generator(path: Path, model: ReferenceGenerator, word2index: dict[str, int], source: str) -> Path:
    return save_checkpoint(path, model.state_dict(), kind="reference_generator", config=model.cfg,
                           meta={"word2index": json.dumps(word2index), "source": source})


def save_rvqs(path: Path, rvqs: dict[str, ReferenceRVQ], stats: dict[str, np.ndarray], source: str) -> Path:
    tensors = {f"{r}.{k}": v for r, m in rvqs.items() for k, v in m.state_dict().items()}
    tensors.update({f"norm.{k}": torch.from_numpy(np.asarray(v, dtype=np.float32)) for k, v in stats.items()})
    configs = {r: dataclasses.asdict(m.cfg) for r, m in rvqs.items()}
    return save_checkpoint(path, tensors, kind="reference_rvq", config=rvqs[REGIONS[0]].cfg,
                           meta={"regions": configs, "source": source})


def load_generator(path: str | Path) -> tuple[ReferenceGenerator, dict[str, int]]:
    tensors, meta = load_checkpoint(path, kind="reference_generator")
    model = ReferenceGenerator(config_from_dict(GeneratorConfig, meta["config"]))
    model.load_state_dict(tensors, strict=True)
    return accelerate(model.eval()), json.loads(meta["word2index"])


def load_rvqs(path: str | Path) -> tuple[dict[str, ReferenceRVQ], dict[str, torch.Tensor]]:
    tensors, meta = load_checkpoint(path, kind="reference_rvq")
    regions = json.loads(meta["regions"])
    rvqs = {}
    for r in REGIONS:
        m = ReferenceRVQ(config_from_dict(RVQConfig, regions[r]))
        m.load_state_dict({k[len(r) + 1:]: v for k, v in tensors.items() if k.startswith(r + ".")}, strict=True)
        rvqs[r] = accelerate(m.eval())
    stats = {k[5:]: v for k, v in tensors.items() if k.startswith("norm.")}
    return rvqs, stats


def check_region_dims(rvqs: dict[str, ReferenceRVQ]) -> None:
    for r, m in rvqs.items():
        if m.cfg.input_dim != REGION_DIMS[r]:
            raise ReferenceFileError(f"the {r} RVQ-VAE takes {m.cfg.input_dim} dims, expected {REGION_DIMS[r]}")
