"""Amplitude of generated motion on held-out speech, and the inference-time options that change it.

    data = AmplitudeData.load("../shared/data/beat2")           # held-out clips, the speaker's train / test motion
    row = data.generated(pipe, "gesturelsm", steps=8, cfg=2.0, text=True, seeds=[0, 1])

Held-out speech is `heldout_clips`' policy (the last 20 % of every motion take + the audio-only takes), with
the MFA transcript (`text=True`) or audio-only. Statistics are `metrics.amplitude` pooled over clips x seeds,
and the replay guard against the training motion (the first 80 %) relative to the speaker's held-out motion.

Inference options measured here without touching the samplers (`sampling_options`):
- `seed_latents`: the first window's seed (R, s, D) in the generator's scaled latent space, instead of its
  neutral seed (the mean pose held still). `rest_seeds` draws them from the speaker's own rest moments.
- `guidance_interval` (lo, hi): classifier-free guidance only for sampler times t in [lo, hi) (t = 0 noise,
  t = 1 data), the conditional prediction elsewhere.
"""
from __future__ import annotations

import contextlib
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np
import torch

from ..body import load_body_model
from ..data.beat2 import Beat2Dataset
from ..generator.data import encode_regions
from ..metrics.amplitude import AmplitudeStats, ReplayGuard, pooled_stats, replay_novelty, training_bank
from ..motion.regions import REGIONS
from ..motion.postprocess import postprocess
from ..motion.sequence import MotionSequence
from .clips import EvalClip, heldout_clips


@dataclass
class AmplitudeRow:
    label: str
    stats: AmplitudeStats
    guard: ReplayGuard | None
    raw_jerk: float | None = None           # jerk before post-processing, when the row's motion was smoothed


@dataclass
class AmplitudeData:
    clips: list[EvalClip]
    train: list[MotionSequence]             # the training part of every motion take
    body: object
    smoothing: str = "off"                  # post-processing of generated motion (motion.postprocess), as shipped

    @classmethod
    def load(cls, root: str | Path, body=None) -> "AmplitudeData":
        clips, _ = heldout_clips(root)
        ds = Beat2Dataset(root)
        train = []
        for c in clips:
            if c.motion is not None:
                whole = ds.load(c.name.split("[")[0], with_audio=False, with_text=False).motion   # "name[a:b]"
                train.append(whole.slice(0, whole.num_frames - c.motion.num_frames))
        return cls(clips, train, body or load_body_model())

    def joints(self, m: MotionSequence) -> np.ndarray:
        return self.body.joints(m.poses, m.trans)                          # (T, 55, 3) m, y up

    @property
    def bank(self) -> torch.Tensor:
        if not hasattr(self, "_bank"):
            self._bank = training_bank([self.joints(m) for m in self.train])
        return self._bank

    @property
    def reference(self) -> list[np.ndarray]:
        """The speaker's held-out motion (joints)."""
        return [self.joints(c.motion) for c in self.clips if c.motion is not None]

    def row(self, label: str, motions: list[np.ndarray], guard: bool = True) -> AmplitudeRow:
        g = replay_novelty(motions, self.bank, self.reference) if guard else None
        return AmplitudeRow(label, pooled_stats(motions), g)

    def speaker_rows(self) -> list[AmplitudeRow]:
        """The whole takes first (the reference of the goals: the speaker's style over the whole recording; the
        held-out 20 % alone is a calmer stretch), then the held-out and training parts."""
        train = [self.joints(m) for m in self.train]
        whole = [np.concatenate([a, b]) for a, b in zip(train, self.reference)]   # FK is per frame
        return [self.row("speaker, whole take", whole, guard=False),
                self.row("speaker, held-out 20 %", self.reference),
                self.row("speaker, training 80 %", train, guard=False)]

    def generated(self, pipe, method: str, steps: int, cfg: float, text: bool, seeds: list[int],
                  label: str | None = None, **options) -> AmplitudeRow:
        """`seed_bank`: first-window seeds, generation seed k uses seed_bank[k % len]; other options as
        `sampling_options`."""
        motions = []
        bank = options.pop("seed_bank", None)
        speech = [pipe.prepare_speech(c.audio, 16000, words=c.words if text else None) for c in self.clips]
        for k in seeds:
            first = bank[k % len(bank)] if bank else None
            with sampling_options(pipe.generators[method], seed_latents=first, **options):
                for sp in speech:
                    motions.append(pipe.generate(sp, steps=steps, cfg=cfg, seed=k, method=method, output="raw").motion)
        mode = "transcript" if text else "audio-only"
        row = self.row(label or f"{method} {steps} steps CFG {cfg:g} {mode}",
                       [self.joints(postprocess(m, False, self.smoothing)) for m in motions])
        if self.smoothing != "off":
            row.raw_jerk = pooled_stats([self.joints(m) for m in motions]).jerk
        return row


@contextlib.contextmanager
def sampling_options(model, seed_latents: torch.Tensor | None = None,
                     guidance_interval: tuple[float, float] | None = None) -> Iterator[None]:
    """Temporarily change a generator's first-window seed and/or restrict CFG to an interval of t."""
    old_seed, old_bind = model.neutral_seed.clone(), model.bind
    try:
        if seed_latents is not None:
            model.neutral_seed.copy_(seed_latents.to(model.neutral_seed))
        if guidance_interval is not None:
            lo, hi = guidance_interval

            def bind(*a, **k):
                f = old_bind(*a, **k)

                def g(x, t, d, drop, **kw):
                    if drop.any() and not (lo <= float(t[0]) < hi):               # CFG batch outside interval
                        n = x.shape[0] // 2
                        y = f(x[:n], t[:n], d[:n], drop[:n], **kw)
                        return torch.cat([y, y])                                   # guided = conditional
                    return f(x, t, d, drop, **kw)
                return g
            model.bind = bind
        yield
    finally:
        model.neutral_seed.copy_(old_seed)
        if guidance_interval is not None:
            del model.bind                                                         # back to the class method


@torch.no_grad()
def rest_seeds(pipe, method: str, train: list[MotionSequence], count: int = 8, quantile: float = 0.25
               ) -> list[torch.Tensor]:
    """`count` first-window seeds (R, s, D), scaled like the generator's latents, from the speaker's rest
    moments: the s-latent spans of the training motion whose upper-body rotation change is in the lowest
    `quantile`, spread evenly over those spans (deterministic)."""
    model = pipe.generators[method]
    s = model.config.seed_latents
    spans = []
    for m in train:
        feats = m.to_features()                                                    # (T, 433)
        lat = encode_regions(pipe.tokenizers, feats) / model.latent_std.cpu()[:, None, None]   # (R, L, D)
        cols = list(REGIONS["upper"].columns)
        motion = (feats[1:, cols] - feats[:-1, cols]).abs().mean(1)                # (T-1,) upper-body change
        for a in range(0, lat.shape[1] - s + 1, s):
            spans.append((float(motion[4 * a:4 * (a + s)].mean()), lat[:, a:a + s]))
    spans.sort(key=lambda p: p[0])
    calm = spans[:max(count, int(len(spans) * quantile))]
    idx = np.linspace(0, len(calm) - 1, count).round().astype(int)
    return [calm[i][1].clone() for i in idx]


def format_rows(rows: list[AmplitudeRow], speaker: AmplitudeStats | None = None) -> str:
    """Markdown table; with `speaker`, each statistic's ratio to the speaker's in brackets."""
    def r(v: float, ref: float) -> str:
        return f" ({v / ref:.2f})" if speaker is not None and ref else ""

    out = ["| motion | raised share | wrist height p50 / p95 (m) | wrist speed (m/s) | hand spread (m) | jerk (m/s^3) "
           "| replay guard (novelty vs speaker) |", "|---|---|---|---|---|---|---|"]
    for row in rows:
        s, sp = row.stats, speaker or row.stats
        guard = f"{row.guard.ratio:.2f} ({row.guard.generated:.3f} / {row.guard.reference:.3f} m)" if row.guard else "-"
        out.append(f"| {row.label} | {100 * s.raised_share:.1f} %{r(s.raised_share, sp.raised_share)} "
                   f"| {s.height_p50:.2f} / {s.height_p95:.2f}{r(s.height_p95, sp.height_p95)} "
                   f"| {s.wrist_speed:.2f}{r(s.wrist_speed, sp.wrist_speed)} | {s.hand_spread:.2f} "
                   f"| {s.jerk:.1f}{'' if row.raw_jerk is None else f' (raw {row.raw_jerk:.1f})'} | {guard} |")
    return "\n".join(out)
