"""Synthetic speech with known word onsets, from the eSpeak NG library (Debian package `espeak-ng`).

A short-lived worker process (`_espeak_worker.py`, ctypes, no package imports) speaks the transcript in each
requested voice and reports eSpeak's word events. A fresh process per call makes the output reproducible
(eSpeak carries state from one utterance to the next) and keeps the C library out of this process. Nothing
is downloaded: the voices ship with the package. Cost: ~0.1 s start-up plus ~2 ms per second of speech.
"""
from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import Unavailable

DEFAULT_VOICE = "en-us"
_WORKER = Path(__file__).with_name("_espeak_worker.py")


class TTSUnavailable(Unavailable):
    """eSpeak NG is not installed or a voice is missing; the message says what to do."""


@dataclass(frozen=True)
class Synthesis:
    """Synthetic speech (at eSpeak's own rate, 22.05 kHz) and the onset (s) of each word given."""

    audio: np.ndarray    # (N,) float32 in [-1, 1]
    sr: int
    starts: np.ndarray   # (W,) seconds, non-decreasing
    voice: str


def synthesize(words: list[str], voices: tuple[str, ...] | list[str] = (DEFAULT_VOICE,), rate_wpm: int = 175,
               timeout_s: float = 120.0) -> list[Synthesis]:
    """Speak `words` (normalised: lowercase letters, apostrophes, inner spaces) joined by single spaces, once
    per voice. Voices eSpeak does not have are left out; TTSUnavailable when none could be used.

    A word with no event of its own (eSpeak merges some short function words into the next one) gets an
    onset interpolated between its neighbours by character count."""
    text = " ".join(words)
    request = json.dumps({"text": text, "voices": list(voices), "rate": int(rate_wpm)}).encode()
    try:
        proc = subprocess.run([sys.executable, "-I", str(_WORKER)], input=request, capture_output=True,
                              timeout=timeout_s, check=False)
    except subprocess.TimeoutExpired:
        raise TTSUnavailable(f"eSpeak NG took longer than {timeout_s:.0f} s") from None
    header, _, body = proc.stdout.partition(b"\n")
    try:
        meta = json.loads(header)
    except ValueError:
        detail = proc.stderr.decode(errors="replace").strip().splitlines()
        raise TTSUnavailable("eSpeak NG failed" + (f": {detail[-1]}" if detail else "")) from None
    if "error" in meta:
        raise TTSUnavailable(meta["error"])
    offsets = np.cumsum([0] + [len(w) + 1 for w in words]) + 1  # eSpeak counts characters from 1
    pcm = np.frombuffer(body, dtype=np.int16)
    out, pos, errors = [], 0, []
    for v in meta["voices"]:
        if "error" in v:
            errors.append(v["error"])
            continue
        audio = pcm[pos:pos + v["samples"]].astype(np.float32) / 32768.0
        pos += v["samples"]
        starts = np.full(len(words), np.nan)
        for tpos, sample in v["events"]:
            k = int(np.searchsorted(offsets, tpos, side="right")) - 1
            if 0 <= k < len(words) and np.isnan(starts[k]):
                starts[k] = sample / meta["sr"]
        weights = np.array([len(w) + 1 for w in words], float)
        out.append(Synthesis(audio, int(meta["sr"]), _fill_missing(starts, weights, len(audio) / meta["sr"]),
                             v["voice"]))
    if not out:
        raise TTSUnavailable("; ".join(errors) or "eSpeak NG produced no audio")
    return out


def available() -> bool:
    """True when eSpeak NG can be used here."""
    try:
        synthesize(["test"])
        return True
    except TTSUnavailable:
        return False


def _fill_missing(starts: np.ndarray, weights: np.ndarray, total: float) -> np.ndarray:
    """Interpolate missing onsets in character-count units; the result is non-decreasing."""
    cum = np.concatenate([[0.0], np.cumsum(weights)[:-1]])
    ok = ~np.isnan(starts)
    if not ok.any():
        return cum / max(weights.sum(), 1.0) * total
    starts = starts.copy()
    starts[~ok] = np.interp(cum[~ok], cum[ok], starts[ok])
    return np.maximum.accumulate(starts)
