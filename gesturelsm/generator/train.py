"""Training loop for the generator (`gesturelsm train`), single process or DistributedDataParallel under
torchrun (gloo on CPU, nccl on CUDA). Tokenizers are frozen; the speech encoder trains with the denoiser."""
from __future__ import annotations

import copy
import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import torch
import torch.distributed as dist
from tqdm import tqdm

from ..errors import InputError
from ..flows import training_method
from ..motion.regions import REGIONS
from ..safe_load import load_tensors
from ..tokenizer.model import RVQVAE
from .config import PRESETS, GeneratorConfig
from .data import LatentWindowSampler, TakeTensors, encode_regions
from .distributed import setup_processes
from .model import GestureGenerator


@dataclass(frozen=True)
class GenTrainConfig:
    method: str = "gesturelsm"       # a key of flows.METHODS
    preset: str = "small"
    steps: int = 4000
    batch_size: int = 32
    lr: float = 2e-4
    betas: tuple[float, float] = (0.5, 0.999)   # the reference's Adam betas
    warmup: int = 200
    grad_clip: float = 1.0
    cond_drop: float = 0.1           # classifier-free guidance dropout
    text_drop: float = 0.2           # transcript dropout (trains audio-only mode)
    neutral_seed_p: float = 0.1      # windows started from the neutral seed
    seed_noise: float = 0.0          # std of noise added to real seed latents (robust window-to-window rollout)
    ema: float = 0.999               # EMA weights are what gets exported (decay warms up: see ema_decay)
    ema_teacher: bool = False        # shortcut targets from the EMA network (Shortcut Models) or online
    time_sampler: str = "beta"       # gesturelsm: beta | uniform | logit_normal
    prediction: str = "data"         # flows: the network predicts x1 ("data", loss on x1) or the velocity (paper)
    seed: int = 0
    eval_every: int = 500
    save_every: int = 500
    device: str = "auto"


def ema_decay(step: int, target: float) -> float:
    """EMA decay after `step` updates: (1 + step) / (10 + step), capped at `target`. A fixed 0.999 from the
    first step would leave 0.999^n of the random initial weights in the average (30 % after 1200 steps)."""
    return min(target, (1 + step) / (10 + step))


@torch.no_grad()
def latent_stats(tokenizers: dict[str, RVQVAE], takes: list[TakeTensors], cfg: GeneratorConfig
                 ) -> tuple[torch.Tensor, torch.Tensor]:
    """Per-region std of the training latents, and the neutral seed: the scaled latents of the mean pose
    (normalised features = 0) held still for one window; its last `seed_latents` frames."""
    std = torch.cat([tk.latents for tk in takes], dim=1).std(dim=(1, 2)).clamp_min(1e-3)     # (R,)
    zeros = torch.zeros(cfg.window_frames, 433)
    for region, tok in tokenizers.items():  # raw mean pose = normaliser mean
        zeros[:, list(REGIONS[region].columns)] = tok.normalizer.mean
    neutral = encode_regions(tokenizers, zeros)[:, -cfg.seed_latents:] / std[:, None, None]
    return std, neutral


def _build_model(takes: list[TakeTensors], tokenizers: dict[str, RVQVAE], tc: GenTrainConfig, method,
                 config: GeneratorConfig | None) -> tuple[GeneratorConfig, GestureGenerator, torch.Tensor,
                                                          torch.Tensor]:
    """The generator for `tc`'s method on the tokenizers' latents, with its latent std and neutral seed set."""
    base = config or PRESETS[tc.preset]
    cfg = GeneratorConfig(**{**asdict(base), "latent_dim": next(iter(tokenizers.values())).config.code_dim,
                             "regions": tuple(tokenizers), "uses_step_size": method.uses_step_size,
                             "prediction": tc.prediction if method.facts.samples_with == "velocity" else "data"})
    model = GestureGenerator(cfg, tc.method)
    std, neutral = latent_stats(tokenizers, takes, cfg)
    model.latent_std.copy_(std)
    model.neutral_seed.copy_(neutral)
    return cfg, model, std, neutral


def _learning_rate(tc: GenTrainConfig, step: int) -> float:
    """Linear warm-up over tc.warmup steps, then cosine decay to 10 % of tc.lr."""
    return tc.lr * min(1.0, (step + 1) / tc.warmup) * (0.5 * (1 + math.cos(math.pi * step / tc.steps)) * 0.9 + 0.1)


def _batch_loss(method, net, model: GestureGenerator, ema: GestureGenerator, b, tc: GenTrainConfig, world: int,
                g: torch.Generator):
    """The method's loss on batch `b`: the network as `f(x, t, d, drop, rows)` (speech encoded once per batch,
    or inside the DDP call), and with tc.ema_teacher the EMA network as the shortcut teacher."""
    cond = model.speech(b.audio, b.words, b.has_word, b.has_text) if world == 1 else None

    def f(x, t, d, drop, rows=None):
        r = slice(None) if rows is None else rows
        if world > 1:  # DDP needs the whole forward inside the wrapped module's call
            return net(x, t, d, None, b.seed[r], drop,
                       speech=(b.audio[r], b.words[r], b.has_word[r], b.has_text[r]))
        assert cond is not None                    # encoded above when world == 1
        return net(x, t, d, cond[r], b.seed[r], drop)

    teacher = None
    if tc.ema_teacher:
        ema_cond = ema.speech(b.audio, b.words, b.has_word, b.has_text)

        def teacher(x, t, d, drop, rows=None):
            r = slice(None) if rows is None else rows
            return ema(x, t, d, ema_cond[r], b.seed[r], drop)
    return method.loss(f, b.x1, tc.cond_drop, generator=g, **({"teacher": teacher} if teacher is not None else {}))


@torch.no_grad()
def _update_ema(ema: GestureGenerator, model: GestureGenerator, decay: float) -> None:
    for pe, pm in zip(ema.parameters(), model.parameters()):
        pe.lerp_(pm, 1 - decay)
    # buffers are not averaged but must follow: the speech encoder's BatchNorm running statistics.
    # (Until this release they stayed at their initial mean 0 / variance 1 in the exported EMA network,
    # so at inference the speech features were mis-scaled and the models learned to ignore speech.)
    for be, bm in zip(ema.buffers(), model.buffers()):
        be.copy_(bm)


def train_generator(takes: list[TakeTensors], heldout: list[TakeTensors], tokenizers: dict[str, RVQVAE],
                    tc: GenTrainConfig, out_path: Path, config: GeneratorConfig | None = None, meta: dict | None = None,
                    log=print) -> GestureGenerator:
    rank, world, device = setup_processes(tc.device)   # process group (gloo/nccl from tc.device), one GPU each
    torch.manual_seed(tc.seed)
    if tc.prediction not in ("data", "velocity"):
        raise InputError(f"prediction must be 'data' or 'velocity' (got {tc.prediction!r})")
    method = training_method(tc.method, tc.prediction, tc.time_sampler)
    cfg, model, std, neutral = _build_model(takes, tokenizers, tc, method, config)
    model.to(device)
    ema = copy.deepcopy(model).eval().requires_grad_(False)
    opt = torch.optim.Adam(model.parameters(), lr=tc.lr, betas=tc.betas)
    state_path = out_path.with_suffix(".state.pt")
    step = 0
    sampler = LatentWindowSampler(takes, cfg.window_latents, cfg.seed_latents, std, neutral, tc.neutral_seed_p,
                                  tc.text_drop, seed=tc.seed + 1000 * rank,
                                  seed_noise=tc.seed_noise)
    if state_path.exists():
        st = load_tensors(state_path, map_location=device)            # tensors only: no code from the file
        model.load_state_dict(st["model"])
        ema.load_state_dict(st["ema"])
        opt.load_state_dict(st["optim"])
        sampler.g.set_state(st["sampler"])
        step = st["step"]
        if rank == 0:
            log(f"resumed {out_path.name} at step {step}")
    net: torch.nn.Module = model
    if world > 1:
        net = torch.nn.parallel.DistributedDataParallel(model,
                                                        device_ids=[device.index] if device.type == "cuda" else None)
    g = torch.Generator(device=device).manual_seed(tc.seed * 7919 + rank * 104729 + step)
    bar = tqdm(total=tc.steps, initial=step, desc=f"train {tc.method}", disable=rank != 0, dynamic_ncols=True,
               mininterval=2)
    model.train()
    t0 = time.time()
    while step < tc.steps:
        lr = _learning_rate(tc, step)
        for grp in opt.param_groups:
            grp["lr"] = lr
        b = sampler.sample(tc.batch_size).to(device)
        res = _batch_loss(method, net, model, ema, b, tc, world, g)
        opt.zero_grad(set_to_none=True)
        res.loss.backward()
        torch.nn.utils.clip_grad_norm_(model.parameters(), tc.grad_clip)
        opt.step()
        _update_ema(ema, model, ema_decay(step, tc.ema))
        step += 1
        bar.update(1)
        if step % 10 == 0:
            bar.set_postfix({k: f"{v:.4f}" for k, v in res.logs.items()} | {"lr": f"{lr:.1e}"})
        if rank == 0 and heldout and (step % tc.eval_every == 0 or step == tc.steps):
            val = heldout_loss(ema, method, heldout, cfg, std, neutral, device)
            bar.write(f"[{tc.method}] step {step}: held-out loss {val:.4f} ({time.time() - t0:.0f}s)")
        if rank == 0 and (step % tc.save_every == 0 or step == tc.steps):
            out_path.parent.mkdir(parents=True, exist_ok=True)
            ema.save(out_path, meta={"step": step, "train": asdict(tc), **(meta or {})})
            torch.save({"model": model.state_dict(), "ema": ema.state_dict(), "optim": opt.state_dict(),
                        "sampler": sampler.g.get_state(), "step": step}, state_path)
    bar.close()
    if world > 1:
        dist.barrier()
    return ema.cpu().eval()


@torch.no_grad()
def heldout_loss(model: GestureGenerator, method, heldout: list[TakeTensors], cfg: GeneratorConfig,
                 std: torch.Tensor, neutral: torch.Tensor, device, n: int = 32) -> float:
    """The method's own loss on held-out windows with fixed noise (comparable across steps)."""
    sampler = LatentWindowSampler(heldout, cfg.window_latents, cfg.seed_latents, std, neutral, 0.0, 0.0, seed=123)
    b = sampler.sample(n).to(device)
    cond = model.speech(b.audio, b.words, b.has_word, b.has_text)
    g = torch.Generator(device=device).manual_seed(0)
    def f(x, t, d, drop, rows=None):
        r = slice(None) if rows is None else rows
        return model(x, t, d, cond[r], b.seed[r], drop)

    return method.loss(f, b.x1, 0.0, generator=g).loss.item()
