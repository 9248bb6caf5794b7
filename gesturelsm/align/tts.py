"""Synthetic speech with known word onsets, from the eSpeak NG library (Debian package `espeak-ng`).

The library is called in-process through ctypes (one call per transcript, ~1 ms per second of speech); its
word events give where each word starts in the synthetic audio. Nothing is downloaded: the voices ship with
the package. eSpeak keeps global state, so calls are serialised with a lock.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import threading
from dataclasses import dataclass

import numpy as np

DEFAULT_VOICE = "en-us"
_LIB_NAMES = ("libespeak-ng.so.1", "libespeak-ng.so", "libespeak-ng.1.dylib", "libespeak-ng.dylib")
_EVENT_WORD, _OUT_SYNCHRONOUS, _INIT_DONT_EXIT = 1, 2, 0x8000
_RATE, _WORDGAP, _CHARS_UTF8 = 1, 7, 1


class TTSUnavailable(RuntimeError):
    """eSpeak NG is not installed or a voice is missing; the message says what to install."""


class _EventId(ctypes.Union):
    _fields_ = [("number", ctypes.c_int), ("name", ctypes.c_char_p), ("string", ctypes.c_char * 8)]


class _Event(ctypes.Structure):  # espeak_EVENT in speak_lib.h
    _fields_ = [("type", ctypes.c_int), ("unique_identifier", ctypes.c_uint), ("text_position", ctypes.c_int),
                ("length", ctypes.c_int), ("audio_position", ctypes.c_int), ("sample", ctypes.c_int),
                ("user_data", ctypes.c_void_p), ("id", _EventId)]


_CALLBACK = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.POINTER(ctypes.c_short), ctypes.c_int, ctypes.POINTER(_Event))


@dataclass(frozen=True)
class Synthesis:
    """Synthetic speech (at eSpeak's own rate, 22.05 kHz) and the onset (s) of each word given."""

    audio: np.ndarray    # (N,) float32
    sr: int
    starts: np.ndarray   # (W,) seconds, non-decreasing


class _Espeak:
    def __init__(self) -> None:
        path = next((p for p in (*_LIB_NAMES, ctypes.util.find_library("espeak-ng")) if p and _loads(p)), None)
        if path is None:
            raise TTSUnavailable("eSpeak NG is not installed (Debian/Ubuntu: apt-get install espeak-ng; "
                                 "macOS: brew install espeak-ng)")
        lib = ctypes.CDLL(path)
        lib.espeak_Synth.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_uint, ctypes.c_int,
                                     ctypes.c_uint, ctypes.c_uint, ctypes.POINTER(ctypes.c_uint), ctypes.c_void_p]
        lib.espeak_SetVoiceByName.argtypes = [ctypes.c_char_p]
        self.rate = lib.espeak_Initialize(_OUT_SYNCHRONOUS, 0, None, _INIT_DONT_EXIT)
        if self.rate <= 0:
            raise TTSUnavailable("eSpeak NG is installed but its data files were not found (espeak-ng-data)")
        self.lib = lib
        self.chunks: list[np.ndarray] = []
        self.events: list[tuple[int, int]] = []  # (text position, sample index) of word events
        self._cb = _CALLBACK(self._on_audio)     # keep a reference: the library holds a raw pointer
        lib.espeak_SetSynthCallback(self._cb)

    def _on_audio(self, wav, n: int, events) -> int:
        if wav and n > 0:
            self.chunks.append(np.ctypeslib.as_array(wav, shape=(n,)).copy())
        k = 0
        while events[k].type != 0:
            if events[k].type == _EVENT_WORD:
                self.events.append((events[k].text_position, events[k].sample))
            k += 1
        return 0

    def speak(self, text: str, voice: str, rate_wpm: int) -> tuple[np.ndarray, list[tuple[int, int]]]:
        if self.lib.espeak_SetVoiceByName(voice.encode()) != 0:
            raise TTSUnavailable(f"eSpeak NG has no voice {voice!r} (list them with: espeak-ng --voices)")
        self.lib.espeak_SetParameter(_RATE, int(rate_wpm), 0)
        self.lib.espeak_SetParameter(_WORDGAP, 0, 0)
        self.chunks, self.events = [], []
        data = text.encode("utf-8") + b"\0"
        self.lib.espeak_Synth(data, len(data), 0, 1, 0, _CHARS_UTF8, None, None)
        self.lib.espeak_Synchronize()
        audio = np.concatenate(self.chunks) if self.chunks else np.zeros(0, np.int16)
        return audio.astype(np.float32) / 32768.0, list(self.events)


def _loads(name: str) -> bool:
    try:
        ctypes.CDLL(name)
        return True
    except OSError:
        return False


_lock = threading.Lock()
_engine: _Espeak | None = None


def available() -> bool:
    try:
        _get()
        return True
    except TTSUnavailable:
        return False


def _get() -> _Espeak:
    global _engine
    if _engine is None:
        _engine = _Espeak()
    return _engine


def synthesize(words: list[str], voice: str = DEFAULT_VOICE, rate_wpm: int = 175) -> Synthesis:
    """Speak `words` (already normalised: letters, apostrophes, inner spaces) joined by single spaces.

    A word with no event of its own (eSpeak merges some short function words into the next) gets an onset
    interpolated between its neighbours by character count."""
    text = " ".join(words)
    offsets, pos = [], 1  # eSpeak counts characters from 1
    for w in words:
        offsets.append(pos)
        pos += len(w) + 1
    with _lock:
        engine = _get()
        audio, events = engine.speak(text, voice, rate_wpm)
        sr = engine.rate
    starts = np.full(len(words), np.nan)
    bounds = np.array(offsets + [pos])
    for tpos, sample in events:
        k = int(np.searchsorted(bounds, tpos, side="right")) - 1
        if 0 <= k < len(words) and np.isnan(starts[k]):
            starts[k] = sample / sr
    starts = _fill_missing(starts, np.array([len(w) + 1 for w in words], float), len(audio) / sr)
    return Synthesis(audio, sr, starts)


def _fill_missing(starts: np.ndarray, weights: np.ndarray, total: float) -> np.ndarray:
    """Interpolate missing onsets in character-count units; force the result to be non-decreasing."""
    ok = ~np.isnan(starts)
    if not ok.any():
        cum = np.concatenate([[0.0], np.cumsum(weights)[:-1]])
        return cum / max(weights.sum(), 1.0) * total
    cum = np.concatenate([[0.0], np.cumsum(weights)[:-1]])
    starts = starts.copy()
    starts[~ok] = np.interp(cum[~ok], cum[ok], starts[ok])
    return np.maximum.accumulate(starts)
