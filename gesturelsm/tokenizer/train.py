"""Training loop for the per-region RVQ-VAE tokenizers (`gesturelsm train-tokenizer`)."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import torch
from tqdm import tqdm

from ..data.split import Split, WindowSampler
from ..motion.normalize import Normalizer
from ..motion.regions import GENERATED_REGIONS, REGIONS
from ..motion.sequence import mirror_features
from ..safe_load import load_tensors
from .config import preset
from .evaluate import reconstruction_error
from .model import RVQVAE


@dataclass(frozen=True)
class TrainConfig:
    preset: str = "small"
    regions: tuple[str, ...] = GENERATED_REGIONS
    steps: int = 3000
    batch_size: int = 64
    window: int = 64                 # frames per training crop (multiple of 4)
    lr: float = 2e-4
    lr_min_ratio: float = 0.1        # cosine decay to lr * this
    weight_decay: float = 0.0
    seed: int = 0
    eval_every: int = 500
    save_every: int = 500
    mirror: bool = True
    device: str = "auto"
    threads: int = 0                 # torch CPU threads (0 = leave torch's default)
    extra: dict = field(default_factory=dict)


def cosine_lr(cfg: TrainConfig, step: int) -> float:
    """Cosine decay from cfg.lr to cfg.lr * cfg.lr_min_ratio over cfg.steps."""
    return cfg.lr * (cfg.lr_min_ratio + (1 - cfg.lr_min_ratio) * 0.5 * (1 + math.cos(math.pi * step / cfg.steps)))


def pick_device(name: str) -> torch.device:
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    return torch.device(name)


def fit_normalizer(split: Split, mirror: bool) -> Normalizer:
    frames = torch.cat(split.train)
    if mirror:  # training sees mirrored crops, so the statistics cover both sides
        frames = torch.cat([frames, mirror_features(frames)])
    return Normalizer.fit(frames)


def train_region(region: str, split: Split, cfg: TrainConfig, out_dir: Path, log=print) -> RVQVAE:
    """Train (or resume) one region's tokenizer; writes out_dir/<region>.safetensors and a resume state."""
    torch.manual_seed(cfg.seed)
    device = pick_device(cfg.device)
    cols = list(REGIONS[region].columns)
    norm = fit_normalizer(split, cfg.mirror).subset(cols)
    model = RVQVAE(preset(cfg.preset, len(cols)), region, norm).to(device)
    opt = torch.optim.AdamW(model.parameters(), lr=cfg.lr, betas=(0.9, 0.99), weight_decay=cfg.weight_decay)
    sampler = WindowSampler(split.train, cfg.window, cfg.mirror, seed=cfg.seed)
    out_dir.mkdir(parents=True, exist_ok=True)
    ckpt, state_path = out_dir / f"{region}.safetensors", out_dir / f"{region}.state.pt"
    step = 0
    if state_path.exists() and ckpt.exists():  # resume
        st = load_tensors(state_path, map_location=None)              # tensors only: no code from the file
        model = RVQVAE.load(ckpt).to(device)
        model.load_state_dict(st["model"])
        opt.load_state_dict(st["optim"])
        sampler.set_state(st["sampler"])
        torch.set_rng_state(st["torch_rng"])
        step = st["step"]
        log(f"[{region}] resumed at step {step}")
    model.train()
    heldout = [h for h in split.heldout if h.shape[0] >= 8]
    bar = tqdm(total=cfg.steps, initial=step, desc=f"tokenizer {region}", dynamic_ncols=True, mininterval=2)
    t0 = time.time()
    while step < cfg.steps:
        lr = cosine_lr(cfg, step)
        for g in opt.param_groups:
            g["lr"] = lr
        x = norm.normalize(sampler.sample(cfg.batch_size)[..., cols]).to(device)  # (B, W, C)
        out = model(x)
        opt.zero_grad(set_to_none=True)
        out.loss.backward()
        torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
        opt.step()
        step += 1
        bar.update(1)
        if step % 20 == 0 or step == cfg.steps:
            resets = sum(layer.num_resets for layer in model.rvq.quantizers)
            for layer in model.rvq.quantizers:
                layer.num_resets = 0
            bar.set_postfix(loss=f"{out.recon_loss.item():.4f}", ppl=f"{out.quant.perplexity[0].item():.0f}",
                            use=f"{out.quant.usage[:out.quant.num_layers].mean().item():.2f}", dead=resets)
        if heldout and (step % cfg.eval_every == 0 or step == cfg.steps):
            model.eval()
            err = reconstruction_error(model, heldout)
            model.train()
            bar.write(f"[{region}] step {step}: held-out rotation error {err:.2f} deg ({time.time() - t0:.0f}s)")
        if step % cfg.save_every == 0 or step == cfg.steps:
            model.save(ckpt, meta={"step": step, "data": split.policy, "train_config": cfg.__dict__})
            torch.save({"model": model.state_dict(), "optim": opt.state_dict(), "sampler": sampler.state(),
                        "torch_rng": torch.get_rng_state(), "step": step}, state_path)
    bar.close()
    return model.eval()


def tune_decoder(model: RVQVAE, split: Split, cfg: TrainConfig, accel_weight: float, log=print) -> RVQVAE:
    """Fine-tune only the decoder of a trained tokenizer, with `accel_weight` on the second-difference error
    (`RVQVAE.reconstruction_loss`), on the training crops encoded and re-quantised by the frozen encoder and
    codebooks. The encoder, the codebooks and so every latent and code stay bitwise as they were, so generators
    trained on this tokenizer's latents stay valid; only what the codes decode to changes (less jitter).
    The config saved with the model records `accel_weight`."""
    torch.manual_seed(cfg.seed)
    device = pick_device(cfg.device)
    model = model.to(device).float()
    model.config = replace(model.config, accel_weight=accel_weight)
    cols = list(REGIONS[model.region].columns)
    for p in model.parameters():
        p.requires_grad_(False)
    params = list(model.decoder.parameters())
    for p in params:
        p.requires_grad_(True)
    opt = torch.optim.AdamW(params, lr=cfg.lr, betas=(0.9, 0.99), weight_decay=cfg.weight_decay)
    sampler = WindowSampler(split.train, cfg.window, cfg.mirror, seed=cfg.seed)
    heldout = [h for h in split.heldout if h.shape[0] >= 8]
    model.eval()                                   # encoder and quantizer: no dropout, no EMA updates
    if heldout:
        error = reconstruction_error(model, heldout)
        log(f"[{model.region}] decoder tuning: held-out rotation error {error:.2f} deg at start")
    for step in range(1, cfg.steps + 1):
        lr = cosine_lr(cfg, step)
        for g in opt.param_groups:
            g["lr"] = lr
        x = model.normalizer.normalize(sampler.sample(cfg.batch_size)[..., cols]).to(device)  # (B, W, C)
        with torch.no_grad():
            z = model.encode(x)
            zq = model.quantize(z).quantized.reshape(z.shape)
        model.decoder.train()
        loss = model.reconstruction_loss(model.decode(zq), x)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        torch.nn.utils.clip_grad_norm_(params, 1.0)
        opt.step()
        if heldout and (step % cfg.eval_every == 0 or step == cfg.steps):
            log(f"[{model.region}] decoder step {step}: loss {loss.item():.4f}, held-out rotation error "
                f"{reconstruction_error(model, heldout):.2f} deg")
    for p in model.parameters():
        p.requires_grad_(False)
    return model.eval()
