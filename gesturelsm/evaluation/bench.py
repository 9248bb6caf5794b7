"""Speed and memory of generation on this machine, every row from one run so that ratios hold on a noisy
machine (configurations are timed in interleaved rounds and the median is kept).

Per preset ("shipped": the checkpoints; "paper": the paper's generator size with random weights on the same
tokenizers, for timing only) x method x steps:
- ms / step: one denoiser call on a CFG pair (batch 2) of one 128-frame window, speech K/V cached.
- AITS: generation seconds for one clip of one window (128 frames, 4.27 s): audio features + sampling +
  decoding, transcript alignment excluded (the paper's convention). Features are computed once per input;
  sampling + decoding is the wall time of the generate call with the device synchronised before and after
  (timing.timed), so GPU figures do not depend on a copy to the CPU to wait for the kernels.
- Every row and report names its hardware (the GPU's name, or "cpu: <model name>"; timing.hardware_name).
- RTF 10 s / 60 s: seconds of speech per second of generation for 10 s and 60 s of speech (60 s only for
  `long_presets`, in the same interleaved rounds). Peak memory: one more 60 s call per configuration after
  the rounds, the peak resident memory during it above the process's level before it (models loaded and
  warm); on CUDA the peak allocated GPU memory. The process's overall peak RSS is in the JSON.
- Ratios: GestureLSM 8 steps against the baselines, per clip (AITS) and for 60 s of speech.
- End to end: an uploaded file to a finished video (decode audio, align the transcript if any, generate,
  render) for the shipped GestureLSM at 8 steps; run twice, the second (a warm app) is reported and the
  first request's total beside it.
"""
from __future__ import annotations

import os
import platform
import statistics
import threading
import time
from dataclasses import replace
from pathlib import Path
from typing import Callable

import numpy as np
import torch

from ..audio import load_audio
from ..backends import checkpoint_sources
from ..constants import FPS, SAMPLE_RATE
from ..flows import make_method
from ..generator.config import PRESETS
from ..generator.model import GestureGenerator
from ..pipeline import GesturePipeline
from ..reference.config import GeneratorConfig as ReferenceConfig
from ..render import render_video
from .timing import hardware_name, synchronize, timed

Log = Callable[[str], None]
DEFAULT_STEPS = (1, 2, 4, 8, 20)


class PeakRSS:
    """Peak resident memory (bytes) of this process above its level at entry, sampled every 2 ms."""

    def __init__(self):
        self._page = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096

    def _rss(self) -> int:
        try:
            with open("/proc/self/statm") as fh:
                return int(fh.read().split()[1]) * self._page
        except OSError:
            return 0

    def __enter__(self):
        self.base = self.peak = self._rss()
        self._stop = threading.Event()
        self._t = threading.Thread(target=self._poll, daemon=True)
        self._t.start()
        return self

    def _poll(self):
        while not self._stop.is_set():
            self.peak = max(self.peak, self._rss())
            self._stop.wait(0.002)

    def __exit__(self, *exc):
        self._stop.set()
        self._t.join()
        self.peak = max(self.peak, self._rss())

    @property
    def megabytes(self) -> float:
        return (self.peak - self.base) / 2 ** 20


def speech_clip(seconds: float, source: np.ndarray | None = None) -> np.ndarray:
    """`seconds` of speech: the start of `source` when long enough (looped otherwise), else synthetic."""
    n = int(round(seconds * SAMPLE_RATE))
    if source is not None and len(source):
        reps = int(np.ceil(n / len(source)))
        return np.tile(source, reps)[:n].astype(np.float32)
    rng = np.random.default_rng(0)
    t = np.arange(n) / SAMPLE_RATE
    env = np.clip(np.sin(2 * np.pi * 3.1 * t), 0, None) ** 2 * (0.8 + 0.2 * rng.random(n))
    return (0.3 * env * np.sin(2 * np.pi * 180 * t)).astype(np.float32)


def paper_pipeline(shipped, device: str = "cpu"):
    """The paper-size generator for every shipped method (random weights), on the shipped tokenizers."""
    torch.manual_seed(0)
    gens = {}
    for name, g in shipped.generators.items():
        c = replace(PRESETS["paper"], regions=g.config.regions, latent_dim=g.config.latent_dim,
                    uses_step_size=make_method(name).uses_step_size)
        gens[name] = GestureGenerator(c, name).eval().to(device)
    return GesturePipeline.from_models(shipped.tokenizers, gens, device, shipped.max_seconds)


def ms_per_step(gen, repeats: int = 20) -> float:
    c = gen.config
    dev = next(gen.parameters()).device
    cond = torch.randn(1, c.window_latents, c.cond_dim, device=dev)
    seed = torch.randn(1, c.num_regions, c.seed_latents, c.latent_dim, device=dev)
    x = torch.randn(2, c.num_regions, c.window_latents, c.latent_dim, device=dev)
    t = torch.full((2,), 0.5, device=dev)
    drop = torch.tensor([False, True], device=dev)
    with torch.inference_mode():
        f = gen.bind(cond, seed)
        f(x, t, t, drop)
        ts = [timed(lambda: f(x, t, t, drop), dev)[1] for _ in range(repeats)]
    return statistics.median(ts) * 1000


def run_bench(checkpoints=None, presets=("shipped", "paper"), methods: list[str] | None = None,
              steps: tuple[int, ...] = DEFAULT_STEPS, cfg: float = 2.0, repeats: int = 3, device: str = "cpu",
              speech: np.ndarray | None = None, long_seconds: float = 60.0, end_to_end: dict | None = None,
              log: Log | None = None, long_presets: tuple[str, ...] = ("shipped", "paper")) -> dict:
    """-> JSON-ready report. `end_to_end`: {"audio": path, "text": str | None, "out": mp4 path} or None."""
    log = log or (lambda m: None)
    shipped = GesturePipeline.from_pretrained(checkpoints=checkpoint_sources(checkpoints), device=device,
                                              methods=methods)
    pipes = {"shipped": shipped}
    if "paper" in presets:
        pipes["paper"] = paper_pipeline(shipped, device)
    pipes = {k: v for k, v in pipes.items() if k in presets}
    clip_frames = next((g.config.window_frames for g in shipped.generators.values()), ReferenceConfig().frames)
    lengths = {"clip": clip_frames / FPS, "10s": 10.0, **({"long": long_seconds} if long_seconds else {})}
    shipped.prepare_speech(speech_clip(2.0, speech), SAMPLE_RATE,
                           transcribe=False)  # warm-up: lazy imports, first calls
    inputs = {k: shipped.prepare_speech(speech_clip(s, speech), SAMPLE_RATE, transcribe=False)   # audio-only inputs
              for k, s in lengths.items()}
    plan = [(p, m, s) for p, pipe in pipes.items() for m in pipe.methods for s in steps]
    times: dict[tuple, dict[str, list[float]]] = {k: {"clip": [], "10s": [], "long": []} for k in plan}
    for rnd in range(repeats + 1):                              # round 0 warms up and is discarded
        for key in plan:
            p, m, s = key
            for which in ("clip", "10s") + (("long",) if long_seconds and p in long_presets and rnd else ()):
                _, wall = timed(lambda: pipes[p].generate(inputs[which], steps=s, cfg=cfg, method=m, output="raw"),
                                device)
                if rnd:                                         # + the input's (once-per-speech) feature time
                    times[key][which].append(inputs[which].timings.get("features", 0.0) + wall)
        log(f"round {rnd}/{repeats} done")
    rows = []
    hardware = hardware_name(device)
    for key in plan:
        p, m, s = key
        pipe = pipes[p]
        row = {"preset": p, "method": m, "steps": s, "cfg": cfg, "hardware": hardware,
               "denoiser_params_m": sum(x.numel() for x in pipe.backends[m].model.denoiser.parameters()) / 1e6,
               "ms_per_step": ms_per_step(pipe.generators[m]) if m in pipe.generators else None,  # ours only
               "aits": statistics.median(times[key]["clip"]),
               "rtf_10s": lengths["10s"] / statistics.median(times[key]["10s"])}
        if long_seconds and p in long_presets:
            if torch.device(device).type == "cuda":
                torch.cuda.reset_peak_memory_stats()
            with PeakRSS() as mem:
                pipe.generate(inputs["long"], steps=s, cfg=cfg, method=m, output="raw")
                synchronize(device)
            row["long_seconds"] = statistics.median(times[key]["long"])
            row["rtf_60s"] = lengths["long"] / row["long_seconds"]
            row["peak_mb"] = (torch.cuda.max_memory_allocated() / 2 ** 20 if torch.device(device).type == "cuda"
                              else mem.megabytes)
        rows.append(row)
        log(f"{p} {m} {s} steps: AITS {row['aits']:.3f} s")
    by = {(r["preset"], r["method"], r["steps"]): r["aits"] for r in rows}
    by_long = {(r["preset"], r["method"], r["steps"]): r["long_seconds"] for r in rows if "long_seconds" in r}
    ratios = {}
    for p in pipes:
        for base, bs in (("ddim", 20), ("rectified_flow", 20), ("ddim", 8), ("rectified_flow", 8)):
            for what, table in (("AITS", by), (f"{long_seconds:g} s of speech", by_long)):
                if (p, "gesturelsm", 8) in table and (p, base, bs) in table:
                    ratios[f"{p}: {base} {bs} steps / GestureLSM 8 steps ({what})"] = (table[(p, base, bs)]
                                                                                   / table[(p, "gesturelsm", 8)])
        if (p, "gesturelsm", 1) in by and (p, "gesturelsm", 8) in by:
            ratios[f"{p}: GestureLSM 8 / 1 steps (AITS)"] = by[(p, "gesturelsm", 8)] / by[(p, "gesturelsm", 1)]
    rep = {"machine": f"{platform.machine()}, {os.cpu_count()} CPUs, {platform.python_version()}, "
                      f"torch {torch.__version__}"
           + (f", {torch.cuda.get_device_name()}" if torch.device(device).type == "cuda" else ""),
           "threads": torch.get_num_threads(), "device": str(device), "hardware": hardware, "repeats": repeats,
           "clip_frames": clip_frames, "clip_seconds": clip_frames / FPS, "rows": rows, "ratios": ratios}
    import resource

    rep["process_peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    if end_to_end:
        cold = time_end_to_end(shipped, **end_to_end)          # first request: text encoder loads, caches fill
        rep["end_to_end"] = time_end_to_end(shipped, **end_to_end)
        rep["end_to_end"]["first_request_total"] = cold["total"]
    return rep


def time_end_to_end(pipe, audio: str | Path, out: str | Path, text: str | None = None, method: str = "gesturelsm",
                    steps: int = 8, cfg: float = 2.0, seconds: float | None = 10.0) -> dict:
    """Upload to video: decode the file, (align the transcript), generate, render the mp4 with the speech."""
    stages = {}
    t0 = time.perf_counter()
    y = load_audio(audio)
    if seconds:
        y = y[: int(seconds * SAMPLE_RATE)]
    stages["decode audio"] = time.perf_counter() - t0
    res = pipe.generate(y, SAMPLE_RATE, text=text, steps=steps, cfg=cfg, method=method, output="raw")
    stages.update({k: v for k, v in res.timings.items()})
    t1 = time.perf_counter()
    render_video([res.motion], y, out)
    stages["render video"] = time.perf_counter() - t1
    return {"method": method, "steps": steps, "seconds_of_speech": len(y) / SAMPLE_RATE, "stages": stages,
            "total": sum(stages.values()), "video": str(out)}
