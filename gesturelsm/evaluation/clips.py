"""Held-out evaluation clips from a BEAT2-layout folder.

Policy (the same as training's `split_features`): with `train_test_split.csv`, every `test` take (val too
with `include_val`) is a clip, whole; without one, the last (1 - train_fraction) of every motion take is held
out (the shipped checkpoints trained on the first 80 %). Takes with speech but no motion (`wave16k/` only)
are audio-only clips: BC and diversity can be measured on them, FGD and face error cannot.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..align.words import Word
from ..audio import SAMPLE_RATE
from ..data.beat2 import Beat2Dataset
from ..errors import DatasetError
from ..motion.sequence import FPS, MotionSequence


@dataclass
class EvalClip:
    name: str
    audio: np.ndarray                  # (N,) 16 kHz mono, sample 0 = motion frame 0
    words: list | None                 # word timings relative to the clip start, or None
    motion: MotionSequence | None      # ground truth, None for audio-only clips

    @property
    def duration(self) -> float:
        return len(self.audio) / SAMPLE_RATE


def _shift_words(words: list | None, t0: float, t1: float) -> list | None:
    if words is None:
        return None
    return [Word(w.text, max(w.start, t0) - t0, min(w.end, t1) - t0) for w in words if w.end > t0 and w.start < t1]


def heldout_clips(root, train_fraction: float = 0.8, speakers=None, audio_only: bool = True,
                  include_val: bool = False, max_clips: int | None = None) -> tuple[list[EvalClip], str]:
    """-> (clips, a sentence describing the policy)."""
    ds = Beat2Dataset(root, speakers=speakers)
    clips: list[EvalClip] = []
    if ds.splits:
        wanted = {"test", "val"} if include_val else {"test"}
        names = [n for n in ds.names if ds.splits.get(n) in wanted]
        for n in names:
            t = ds.load(n)
            if t.audio is not None:
                clips.append(EvalClip(n, t.audio, t.words, t.motion))
        policy = f"train_test_split.csv: {'+'.join(sorted(wanted))} takes, whole"
        extra = [n for n in ds.audio_only_names if ds.splits.get(n) in wanted]
    else:
        for n in ds.names:
            t = ds.load(n)
            if t.audio is None:
                continue
            T = t.motion.num_frames
            cut = int(round(train_fraction * T))
            a0, a1 = cut / FPS, T / FPS
            audio = t.audio[int(round(a0 * SAMPLE_RATE)):int(round(a1 * SAMPLE_RATE))]
            clips.append(EvalClip(f"{n}[{cut}:{T}]", audio, _shift_words(t.words, a0, a1), t.motion.slice(cut, T)))
        pct = round(100 * train_fraction)
        policy = f"no split file: last {100 - pct}% of each motion take held out"
        extra = list(ds.audio_only_names)
    if audio_only:
        for n in extra:
            t = ds.load(n)
            clips.append(EvalClip(n, t.audio, t.words, None))
        if extra:
            policy += f"; {len(extra)} audio-only take(s) (BC and diversity only)"
    if max_clips:
        clips = clips[:max_clips]
    if not clips:
        raise DatasetError(f"{root}: no held-out clips with speech found")
    return clips, policy
