"""Speech augmentation for generator training (`gesturelsm train --augment tempo pitch gain`), off by default.

Each kind adds precomputed variants of every training take (and their left/right mirrors), built once before
training, so a training step costs the same as without augmentation:

- tempo: the speech is time-stretched (phase vocoder, pitch kept) by rate r in TEMPO_RATES, i.e. it lasts 1/r
  as long, and the motion is time-warped by the same factor: frame j of the variant (t = j / 30 s) shows the
  pose of original time t * r (per-joint quaternion interpolation, translation and expressions linear), so
  a gesture stroke that fell on a syllable still falls on it. Word times are divided by r. The latents are
  re-encoded from the warped motion, so the variant is a real T / r-frame clip at 30 fps.
- pitch: the speech is pitch-shifted by PITCH_SEMITONES (length kept); the motion is unchanged.
- gain: the speech is scaled by GAIN_DB (not clipped: the audio channels are floats); the motion is unchanged.

Conventions: 30 fps motion, 16 kHz audio, audio sample 0 = motion frame 0.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import torch

from ..align.words import Word
from ..constants import SAMPLE_RATE
from ..errors import UserError
from ..features.text import TextEmbedder
from ..motion.rotations import axis_angle_to_matrix, matrix_to_quaternion, quaternion_to_axis_angle
from ..motion.sequence import MotionSequence
from ..tokenizer.model import RVQVAE
from .data import TakeTensors, build_take, samples_for
from .variant_kinds import KINDS

TEMPO_RATES = (0.9, 1.1)          # speech rate: 1.1 = 10 % faster (the clip is 1/1.1 as long)
PITCH_SEMITONES = (-2.0, 2.0)
GAIN_DB = (-6.0, 6.0)


@dataclass(frozen=True)
class Variant:
    kind: str      # tempo | pitch | gain
    value: float   # rate | semitones | dB

    @property
    def name(self) -> str:
        return f"{self.kind}{self.value:+g}" if self.kind != "tempo" else f"tempo{self.value:g}"


def variants_for(kinds: list[str] | tuple[str, ...] | None) -> list[Variant]:
    """The variants of the named kinds, in KINDS order; [] for none (augmentation off)."""
    kinds = list(kinds or [])
    bad = [k for k in kinds if k not in KINDS]
    if bad:
        raise UserError(f"--augment {' '.join(bad)}: unknown kind; choose from {', '.join(KINDS)}")
    values = {"tempo": TEMPO_RATES, "pitch": PITCH_SEMITONES, "gain": GAIN_DB}
    return [Variant(k, v) for k in KINDS if k in kinds for v in values[k]]


def warp_motion(m: MotionSequence, rate: float) -> MotionSequence:
    """The motion played `rate` times as fast, still at m.fps: round(T / rate) frames, frame j = original
    time j * rate (frames). Rotations: normalised quaternion interpolation between neighbouring frames (signs
    made continuous first); translation and expressions: linear."""
    T = m.num_frames
    T2 = max(1, int(round(T / rate)))
    src = np.minimum(np.arange(T2) * rate, T - 1)                   # (T2,) source frame positions
    i0 = np.floor(src).astype(np.int64)
    i1 = np.minimum(i0 + 1, T - 1)
    w = torch.from_numpy((src - i0).astype(np.float32))             # (T2,)
    q = matrix_to_quaternion(axis_angle_to_matrix(torch.from_numpy(m.poses).reshape(T, -1, 3)))   # (T, J, 4)
    for t in range(1, T):                                           # continuous hemisphere along time
        flip = (q[t] * q[t - 1]).sum(-1, keepdim=True) < 0
        q[t] = torch.where(flip, -q[t], q[t])
    qi = torch.nn.functional.normalize(q[i0] * (1 - w)[:, None, None] + q[i1] * w[:, None, None], dim=-1)
    poses = quaternion_to_axis_angle(qi).reshape(T2, -1).numpy()

    def lin(x: np.ndarray) -> np.ndarray:
        wn = w.numpy()[:, None]
        return x[i0] * (1 - wn) + x[i1] * wn

    return replace(m, poses=poses, trans=lin(m.trans), expressions=lin(m.expressions))


def perturb_audio(y: np.ndarray, v: Variant, sr: int = SAMPLE_RATE) -> np.ndarray:
    """(N,) float32 -> the variant's audio: (~N / rate,) for tempo, (N,) for pitch and gain."""
    import librosa

    y = np.asarray(y, np.float32)
    if v.kind == "tempo":
        return librosa.effects.time_stretch(y, rate=v.value).astype(np.float32)
    if v.kind == "pitch":
        return librosa.effects.pitch_shift(y, sr=sr, n_steps=v.value).astype(np.float32)
    if v.kind == "gain":
        return y * np.float32(10 ** (v.value / 20))
    raise ValueError(f"unknown augmentation kind {v.kind!r}")


def apply_variant(v: Variant, motion: MotionSequence, audio: np.ndarray, words: list[Word] | None
                  ) -> tuple[MotionSequence, np.ndarray, list[Word] | None]:
    """(motion, 16 kHz audio, words) of one take -> the variant's, aligned: the audio is cut / zero-padded
    to exactly samples_for(motion frames)."""
    y = perturb_audio(audio[: samples_for(motion.num_frames)], v)
    if v.kind == "tempo":
        motion = warp_motion(motion, v.value)
        if words is not None:
            words = [Word(w.text, w.start / v.value, w.end / v.value) for w in words]
    n = samples_for(motion.num_frames)
    out = np.zeros(n, np.float32)
    out[: min(n, len(y))] = y[:n]
    return motion, out, words


def augmented_takes(name: str, motion: MotionSequence, audio: np.ndarray, words: list[Word] | None,
                    tokenizers: dict[str, RVQVAE], embedder: TextEmbedder | None, variants: list[Variant]
                    ) -> list[TakeTensors]:
    """Each variant of one training take and its left/right mirror, as training tensors (2 per variant)."""
    out = []
    for v in variants:
        m, y, w = apply_variant(v, motion, audio, words)
        feats = m.to_features()
        for mirror in (False, True):
            out.append(build_take(f"{name}~{v.name}", feats, y, w, tokenizers, embedder, mirror=mirror))
    return out

