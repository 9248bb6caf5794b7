"""Reader for the BEAT2 dataset's own folder layout.

    ROOT/smplxflame_30/<take>.npz     motion (MotionSequence, 30 fps)
    ROOT/wave16k/<take>.wav           speech (any rate / int or float PCM; resampled to 16 kHz mono)
    ROOT/textgrid/<take>.TextGrid     word timings (optional: text is then absent)
    ROOT/train_test_split.csv         optional: columns `id,type` with type in train / val / test / additional

Take names are `<speaker id>_<speaker name>_<...>` (e.g. `2_scott_0_1_1`). Audio is trimmed (or padded with
silence) to the motion's duration so that audio sample 0 and motion frame 0 are the same instant.
"""
from __future__ import annotations

import csv
import hashlib
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Iterator

import numpy as np
import torch

from ..align.textgrid import read_words
from ..audio import SAMPLE_RATE, AudioError, load_audio
from ..errors import DatasetError
from ..motion.sequence import FPS, MotionSequence
from .training_windows import window_starts

CACHE_VERSION = 1


@dataclass
class Take:
    name: str
    speaker: int
    motion: MotionSequence | None          # None for audio-only takes
    audio: np.ndarray | None               # (N,) float32 16 kHz, trimmed to the motion when there is one
    words: list | None                     # list[gesturelsm.align.Word] or None without a TextGrid
    split: str | None = None

    @property
    def num_frames(self) -> int:
        if self.motion is not None:
            return self.motion.num_frames
        return int(len(self.audio) * FPS / SAMPLE_RATE) if self.audio is not None else 0


def speaker_of(name: str) -> int:
    head = name.split("_", 1)[0]
    return int(head) if head.isdigit() else -1


def match_length(audio: np.ndarray, num_frames: int, fps: int = FPS, sr: int = SAMPLE_RATE) -> np.ndarray:
    """Trim or zero-pad audio to exactly num_frames / fps seconds."""
    n = int(round(num_frames * sr / fps))
    if len(audio) >= n:
        return audio[:n]
    return np.pad(audio, (0, n - len(audio)))


class Beat2Dataset:
    """Index of a BEAT2-layout folder. Files are read lazily by `load`."""

    def __init__(self, root: str | Path, speakers: Iterable[int | str] | None = None,
                 split: str | Iterable[str] | None = None, cache_dir: str | Path | None = None):
        self.root = Path(root)
        if not self.root.is_dir():
            raise DatasetError(f"BEAT2 folder not found: {self.root}")
        self.motion_dir = self.root / "smplxflame_30"
        self.wave_dir = self.root / "wave16k"
        self.text_dir = self.root / "textgrid"
        if not self.motion_dir.is_dir() and not self.wave_dir.is_dir():
            raise DatasetError(f"{self.root} has neither smplxflame_30/ nor wave16k/: not a BEAT2-layout folder")
        self.cache_dir = Path(cache_dir) if cache_dir else None
        self.splits = self._read_split()
        wanted_split = {split} if isinstance(split, str) else (set(split) if split else None)
        ids: set[int] = set()
        spk_names: set[str] = set()
        for s in speakers or ():
            if isinstance(s, int) or str(s).isdigit():
                ids.add(int(s))
            else:
                spk_names.add(str(s).lower())
        names = sorted({p.stem for p in self.motion_dir.glob("*.npz")} if self.motion_dir.is_dir() else set())
        waves = {p.stem for p in self.wave_dir.glob("*.wav")} if self.wave_dir.is_dir() else set()
        audio_only = sorted(waves - set(names))

        def keep(name: str) -> bool:
            if speakers is not None:
                parts = name.split("_")
                if speaker_of(name) not in ids and (len(parts) < 2 or parts[1].lower() not in spk_names):
                    return False
            if wanted_split is not None and self.splits.get(name) not in wanted_split:
                return False
            return True

        self.names = [n for n in names if keep(n)]
        self.audio_only_names = [n for n in audio_only if keep(n)]

    def _read_split(self) -> dict[str, str]:
        path = self.root / "train_test_split.csv"
        if not path.exists():
            return {}
        try:
            with open(path, newline="") as fh:
                rows = list(csv.DictReader(fh))
            return {r["id"].strip(): r["type"].strip() for r in rows}
        except (KeyError, csv.Error, UnicodeDecodeError) as exc:
            raise DatasetError(f"{path}: expected a CSV with columns 'id' and 'type' ({exc})") from None

    def __len__(self) -> int:
        return len(self.names)

    def __iter__(self) -> Iterator[Take]:
        for n in self.names:
            yield self.load(n)

    # ------------------------------------------------------------------------------------------------
    def load(self, name: str, with_audio: bool = True, with_text: bool = True) -> Take:
        npz = self.motion_dir / f"{name}.npz"
        motion = MotionSequence.load(npz) if npz.exists() else None
        audio = None
        wav = self.wave_dir / f"{name}.wav"
        if with_audio and wav.exists():
            try:
                audio = load_audio(wav, SAMPLE_RATE)
            except AudioError as exc:
                raise DatasetError(f"{wav}: {exc}") from None
            if motion is not None:
                audio = match_length(audio, motion.num_frames, motion.fps)
        if motion is None and audio is None:
            raise DatasetError(f"take {name!r} has neither {npz.name} nor {wav.name} in {self.root}")
        words = None
        tg = self.text_dir / f"{name}.TextGrid"
        if with_text and tg.exists():
            words = read_words(tg)
        return Take(name, speaker_of(name), motion, audio, words, self.splits.get(name))

    def features(self, name: str) -> torch.Tensor:
        """(T, 433) motion features of a take, through the on-disk cache when one is configured."""
        npz = self.motion_dir / f"{name}.npz"
        if self.cache_dir is None:
            return MotionSequence.load(npz).to_features()
        key = _cache_key(npz)
        path = self.cache_dir / f"{name}.{key}.pt"
        if path.exists():
            return torch.load(path)
        feats = MotionSequence.load(npz).to_features()
        self.cache_dir.mkdir(parents=True, exist_ok=True)
        for stale in self.cache_dir.glob(f"{name}.*.pt"):  # an older version of the same source
            stale.unlink(missing_ok=True)
        tmp = path.with_suffix(".tmp")
        torch.save(feats, tmp)
        tmp.replace(path)
        return feats


def _cache_key(src: Path) -> str:
    """Changes whenever the source file (path, size, mtime) or the feature code version changes."""
    st = src.stat()
    raw = f"{src.resolve()}|{st.st_size}|{st.st_mtime_ns}|{CACHE_VERSION}"
    return hashlib.sha1(raw.encode()).hexdigest()[:16]


@dataclass
class Window:
    take: str
    start: int                 # first frame
    motion: torch.Tensor       # (L, 433) features (raw, un-normalised)
    audio: np.ndarray | None   # (L / 30 * 16000,) float32 or None
    mirrored: bool = False


def iter_windows(dataset: Beat2Dataset, length: int, stride: int, *, frame_range: tuple[float, float] = (0.0, 1.0),
                 with_audio: bool = False) -> Iterator[Window]:
    """All windows of every take. `frame_range` selects a fraction of each take (e.g. (0, 0.8) = first 80%,
    the train part when a folder has no split file). Takes shorter than one window are skipped with a warning.
    """
    for name in dataset.names:
        feats = dataset.features(name)
        T = feats.shape[0]
        a, b = int(round(frame_range[0] * T)), int(round(frame_range[1] * T))
        starts = window_starts(b - a, length, stride)
        if not starts:
            warnings.warn(f"{name}: {b - a} frames in range, shorter than one {length}-frame window; skipped")
            continue
        audio = dataset.load(name, with_text=False).audio if with_audio else None
        for s in starts:
            s0 = a + s
            clip = None
            if audio is not None:
                i0 = int(round(s0 * SAMPLE_RATE / FPS))
                clip = audio[i0:i0 + int(round(length * SAMPLE_RATE / FPS))]
            yield Window(name, s0, feats[s0:s0 + length], clip)
