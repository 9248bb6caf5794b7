"""Speech -> recognised English words with times, offline (Whisper tiny.en via faster-whisper) + our aligner.

    from gesturelsm.asr import transcribe
    tr = transcribe(audio_16k)          # Transcript(words, text, language, ..., timing_method, warnings)
    if tr.accepted: use tr.words        # else: generate audio-only and show tr.warnings[0] to the user

Audio is (N,) float32 mono at 16 kHz; times are seconds from the first sample.

Word timing: Whisper's own word times (cross-attention DTW) are further from the MFA onsets on the BEAT2 takes
than our eSpeak+DTW aligner run on the recognised text (docs/TRANSCRIPTION.md, benchmarks/transcribe_accuracy.py).
So the recognised text is re-aligned with `gesturelsm.align.align_words`; where that aligner falls back
(low confidence, no eSpeak NG) Whisper's own times are kept instead of spreading the words evenly.

Rejection (never garbage words fed to the text encoder silently): tiny.en is English-only and, given German
or French speech, confidently writes unrelated English ("thank you for watching ..."), but with a low mean
token log-probability (about -1.0 to -1.5 on eSpeak German/French against -0.15 to -0.3 on real and eSpeak
English). Recognitions below MIN_AVG_LOGPROB, or with no words (silence, noise, music), are rejected with a
message; the caller then generates from the audio only.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..align import Word, align_words
from ..constants import SAMPLE_RATE
from .model import MODEL_NAME, RecognizerUnavailable, load_model

MIN_AVG_LOGPROB = -0.6   # mean token log-probability below this: not (clear) English speech
# Greedy decoding: on the real BEAT2 takes it finds nearly every word beam 5 finds, nearly as close in time, with a
# mean log-probability as far above MIN_AVG_LOGPROB, in clearly less time (docs/TRANSCRIPTION.md has the figures,
# from benchmarks/transcribe_accuracy.py --beam-size 1 / 5). The page waits for it when Generate follows an upload.
BEAM_SIZE = 1
# Whisper falls back to sampling at rising temperatures when a 30-s window's greedy text repeats itself (compression
# ratio > 2.4) or is improbable. On tones and chords the greedy text is one phrase repeated, probable enough for
# MIN_AVG_LOGPROB alone to accept it, and the five fallbacks cost several greedy passes to end with no words, while
# real speech's windows do not loop (docs/TRANSCRIPTION.md). So `recognize` decodes greedily once, rejects audio whose
# every window loops, and runs the fallback only where some windows loop.
LOOP_RATIO = 2.4
FALLBACK_TEMPERATURES = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
MIN_SECONDS = 0.3
TIMINGS = ("auto", "dtw", "whisper")
AUDIO_ONLY_NOTE = " Generating from the audio only; type the transcript to use the text-conditioned model."


@dataclass(frozen=True)
class Transcript:
    """What the recogniser heard. `words` is empty unless `accepted`; `heard` keeps the raw text anyway.

    language: "en" when accepted (the model is English-only), else "unknown". language_probability: the
    model gives none (English-only), so None. confidence: exp(mean token log-probability), 0..1.
    timing_method: "dtw" (our aligner on the recognised text), "whisper" (Whisper's word times) or "none"."""

    words: list[Word]
    text: str
    language: str
    language_probability: float | None
    timing_method: str
    warnings: list[str]
    accepted: bool
    confidence: float
    heard: str = ""
    details: dict = field(default_factory=dict, compare=False)


def sequential(words: list[Word], min_s: float = 0.01) -> list[Word]:
    """Whisper's word times made strictly sequential: each word starts no earlier than the previous one ends and
    lasts >= `min_s`. Whisper gives fast words zero length or the same start as their neighbour; left as they
    were, writing them as TextGrid intervals failed ("word 14 has no duration")."""
    out: list[Word] = []
    t = 0.0
    for w in words:
        start = max(w.start, t)
        end = max(w.end, start + min_s)
        out.append(Word(w.text, start, end))
        t = end
    return out


def _decode(audio: np.ndarray, beam_size: int, temperature) -> list:
    segments, _info = load_model().transcribe(np.ascontiguousarray(audio, np.float32), language="en",
                                              beam_size=beam_size, word_timestamps=True,
                                              condition_on_previous_text=False, temperature=temperature)
    return list(segments)


def recognize(audio: np.ndarray, beam_size: int = BEAM_SIZE) -> tuple[list[Word], float, dict]:
    """Whisper's words with its own times, the mean token log-probability (weighted by tokens) and details.

    One greedy pass first (temperature 0). Where every window it decoded is a loop (one phrase repeated: compression
    ratio > LOOP_RATIO), there is no speech to find: no words, details["repeated_phrase"] = True. Where only some
    windows loop, the audio is decoded again with Whisper's temperature fallback (FALLBACK_TEMPERATURES)."""
    segments = _decode(audio, beam_size, 0.0)
    loops = [seg.compression_ratio > LOOP_RATIO for seg in segments]
    if segments and all(loops):
        return [], -math.inf, {"model": MODEL_NAME, "mean_word_probability": 0.0, "repeated_phrase": True,
                               "heard_repeated": _clip(" ".join(segments[0].text.split())),
                               "max_no_speech_probability": max(float(seg.no_speech_prob) for seg in segments)}
    if any(loops):
        segments = _decode(audio, beam_size, list(FALLBACK_TEMPERATURES))
    words: list[Word] = []
    logp, ntok, probs, no_speech = 0.0, 0, [], []
    for seg in segments:
        n = max(1, len(seg.tokens))
        logp, ntok = logp + seg.avg_logprob * n, ntok + n
        no_speech.append(float(seg.no_speech_prob))
        for w in seg.words or []:
            text = w.word.strip()
            if text:
                words.append(Word(text, float(w.start), float(w.end)))
                probs.append(float(w.probability))
    words = sequential(words)
    avg = logp / ntok if ntok else -math.inf
    details = {"model": MODEL_NAME, "mean_word_probability": float(np.mean(probs)) if probs else 0.0,
               "max_no_speech_probability": max(no_speech, default=1.0)}
    return words, avg, details


def transcribe(audio: np.ndarray, timing: str = "auto", beam_size: int = BEAM_SIZE) -> Transcript:
    """Recognise `audio` ((N,) float32, 16 kHz) and time its words. Raises RecognizerUnavailable when
    faster-whisper or the weights are not installed; every other outcome is a Transcript (see its doc)."""
    if timing not in TIMINGS:
        raise ValueError(f"timing must be one of {TIMINGS} (got {timing!r})")
    y = np.asarray(audio, np.float32).reshape(-1)
    if len(y) < MIN_SECONDS * SAMPLE_RATE or not np.isfinite(y).all() or np.abs(y).max() < 1e-4:
        return _rejected("The audio is too short, silent or invalid: there is no speech to recognise.")
    words, avg, details = recognize(y, beam_size)
    heard = " ".join(w.text for w in words)
    conf = math.exp(avg) if words else 0.0
    details["avg_logprob"] = avg
    if details.get("repeated_phrase"):
        phrase = details["heard_repeated"]
        return _rejected(f"Automatic transcription was rejected: the English speech recogniser only heard one phrase "
                         f"over and over (\"{phrase}\"). The speech may not be English, or it is music, tones or "
                         "noise.", phrase, 0.0, details)
    if not words:
        return _rejected("No speech was recognised (silence, noise or music?).", details=details)
    if avg < MIN_AVG_LOGPROB:
        return _rejected(f"Automatic transcription was rejected: the English speech recogniser is unsure of what it "
                         f"heard (confidence {conf:.2f}; it heard \"{_clip(heard)}\"). The speech may not be English, "
                         "or it is noise or music.", heard, conf, details)
    timed, method, warnings = _timed(y, words, heard, timing)
    return Transcript(timed, heard, "en", None, method, warnings, True, conf, heard, details)


def _timed(y: np.ndarray, words: list[Word], text: str, timing: str) -> tuple[list[Word], str, list[str]]:
    if timing == "whisper":
        return words, "whisper", []
    res = align_words(y, text)
    if res.method == "dtw" or timing == "dtw":
        return res.words, "dtw", [res.warning] if res.warning else []
    note = f"Word times are the recogniser's own (the aligner fell back: {res.warning})" if res.warning else None
    return words, "whisper", [note] if note else []


def _rejected(message: str, heard: str = "", conf: float = 0.0, details: dict | None = None) -> Transcript:
    return Transcript([], "", "unknown", None, "none", [message + AUDIO_ONLY_NOTE], False, conf, heard, details or {})


def _clip(text: str, n: int = 60) -> str:
    return text if len(text) <= n else text[: n - 3].rstrip() + "..."


__all__ = ["Transcript", "RecognizerUnavailable", "recognize", "sequential", "transcribe", "MIN_AVG_LOGPROB"]
