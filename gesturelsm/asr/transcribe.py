"""Speech -> recognised words with times, offline: English with Whisper tiny.en + our aligner, other languages
with Whisper base (multilingual.py) and its own word times.

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

Other languages (`language`): under AUTO the English model runs first, unchanged; where it rejects the speech as
unsure or looping (or hears no words), the multilingual model identifies the language (MIN_LANGUAGE_PROBABILITY;
English again keeps the rejection) and transcribes it, rejected below MIN_AVG_LOGPROB_OTHER. A chosen language goes
straight to the multilingual model.
"""
from __future__ import annotations

import contextlib
import math
import queue
import threading
from dataclasses import dataclass, field, replace
from typing import Callable, Iterator

import numpy as np

from ..align import AlignConfig, Word, align_words
from ..align.dtw import warm
from ..align.features import frame_time, voice_activity
from ..constants import SAMPLE_RATE
from . import multilingual
from .languages import AUTO, CHOICES, ENGLISH, NO_SPACES, espeak_voice, name
from .model import MODEL_NAME, RecognizerUnavailable, load_model
from .recognition_windows import recognition_cuts

MIN_AVG_LOGPROB = -0.6   # mean token log-probability below this: not (clear) English speech
# The multilingual model (Whisper base) on speech it identified: eSpeak Japanese, Spanish and German score -0.63 to
# -0.76 (robotic voices), so its own bar is lower; below it the words are not trusted (docs/TRANSCRIPTION.md).
MIN_AVG_LOGPROB_OTHER = -1.0
MIN_LANGUAGE_PROBABILITY = 0.5   # an automatic language identification less sure than this is not acted on
# Where tiny.en heard no words at all the bar is higher: eSpeak Japanese sits on Whisper's no-speech rule (no-speech
# probability ~0.6 with a mean log-probability ~-1.0), so tiny.en sometimes drops every window of it, while white noise,
# music and chords are identified as Nynorsk or English at 0.43-0.58 (eSpeak Japanese: 0.90-0.92).
MIN_LANGUAGE_PROBABILITY_NO_WORDS = 0.75
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

    language: the Whisper code of the language heard ("en" from the English model, "ja", "zh", "es", ... from the
    multilingual one) when accepted, else "unknown". language_probability: the multilingual model's identification
    (None for English from the English-only model, or for a language the user chose). confidence: exp(mean token
    log-probability), 0..1.
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


def _decode(audio: np.ndarray, beam_size: int, temperature, model=None, language: str = ENGLISH) -> list:
    segments, _info = (model or load_model()).transcribe(np.ascontiguousarray(audio, np.float32), language=language,
                                                         beam_size=beam_size, word_timestamps=True,
                                                         condition_on_previous_text=False, temperature=temperature)
    return list(segments)


def recognize(audio: np.ndarray, beam_size: int = BEAM_SIZE, model=None,
              language: str = ENGLISH) -> tuple[list[Word], float, dict]:
    """Whisper's words with its own times, the mean token log-probability (weighted by tokens) and details.

    One greedy pass first (temperature 0). Where every window it decoded is a loop (one phrase repeated: compression
    ratio > LOOP_RATIO), there is no speech to find: no words, details["repeated_phrase"] = True. Where only some
    windows loop, the audio is decoded again with Whisper's temperature fallback (FALLBACK_TEMPERATURES).
    `model`: None for the English model, else a loaded model (the multilingual one) decoding `language`."""
    words, logp, ntok, details = _recognized(audio, beam_size, model, language)
    return words, (logp / ntok if ntok else -math.inf), details


def _spoken(segments: list) -> list:
    """The segments with a letter or digit in them. Whisper ends some windows on a segment of punctuation alone (" ."
    over the last second of a short-context piece); its compression ratio is the window's, often over LOOP_RATIO, and
    such a segment holds no words to recover, so it must not set off the fallback's five sampling passes (seconds
    more for the window, which may then end on a made-up word)."""
    return [seg for seg in segments if any(ch.isalnum() for ch in seg.text)]


def _recognized(audio: np.ndarray, beam_size: int, model, language: str) -> tuple[list[Word], float, int, dict]:
    """recognize's words, the sum of token log-probabilities and the token count (to pool windows), details
    (with "word_probabilities": the words' probabilities)."""
    label = MODEL_NAME if model is None else multilingual.MODEL_NAME
    segments = _spoken(_decode(audio, beam_size, 0.0, model, language))
    loops = [seg.compression_ratio > LOOP_RATIO for seg in segments]
    if segments and all(loops):
        return [], 0.0, 0, {"model": label, "mean_word_probability": 0.0, "repeated_phrase": True,
                            "heard_repeated": _clip(" ".join(segments[0].text.split())), "word_probabilities": [],
                            "max_no_speech_probability": max(float(seg.no_speech_prob) for seg in segments)}
    if any(loops):
        segments = _spoken(_decode(audio, beam_size, list(FALLBACK_TEMPERATURES), model, language))
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
    details = {"model": label, "mean_word_probability": float(np.mean(probs)) if probs else 0.0,
               "max_no_speech_probability": max(no_speech, default=1.0), "word_probabilities": probs}
    return sequential(words), logp, ntok, details


@dataclass(frozen=True)
class Piece:
    """The English model's words of one recognition window (asr/recognition_windows.py), timed by our aligner on that
    window's audio; times in seconds from the start of the whole speech. Every word starting before `final_until` is
    known once this piece and the ones before it are (the window's end; infinity for the last window)."""
    words: list[Word]
    final_until: float
    heard: str
    logp: float
    ntok: int
    timing_method: str
    warnings: list[str]
    details: dict


def english_pieces(y: np.ndarray, timing: str = "auto", beam_size: int = BEAM_SIZE) -> Iterator[Piece]:
    """The English model on `y` window by window (windows.recognition_cuts), each window's words timed on its own
    audio (`timing` as `transcribe` takes it). A window whose every Whisper segment loops has no words (its
    details["repeated_phrase"]); `english_transcript` pools the pieces.

    The first window is recognised and timed before anything else (its words are the ones the first motion waits
    for); then window j + 1 is recognised on a thread of its own while window j is handed over and timed, so that
    neither the aligner's work nor what the caller does with a piece (the text features) holds the recogniser up.
    The pieces are the same either way, in order."""
    cuts = recognition_cuts(y)
    spans = list(zip(cuts, cuts[1:]))
    last = len(spans) - 1
    aligner = _aligner_loading(timing)
    first = _recognized(y[spans[0][0]:spans[0][1]], beam_size, None, ENGLISH)
    aligner.join()
    first = _piece(y, *spans[0], *first, timing, last == 0)
    if last == 0:
        yield first
        return
    heard: queue.Queue = queue.Queue(maxsize=1)
    stop = threading.Event()

    def recognise() -> None:
        try:
            for a, b in spans[1:]:
                if stop.is_set():
                    return
                heard.put(((a, b), _recognized(y[a:b], beam_size, None, ENGLISH)))
        except BaseException as exc:       # raised where the pieces are read
            heard.put((None, exc))

    thread = threading.Thread(target=recognise, name="gesturelsm-recognise", daemon=True)
    thread.start()
    try:
        yield first
        for j in range(1, last + 1):
            span, got = heard.get()
            if span is None:
                raise got
            yield _piece(y, *span, *got, timing, j == last)
    finally:
        stop.set()
        with contextlib.suppress(queue.Empty):
            heard.get_nowait()              # a window recognised for nobody: the thread ends


def _aligner_loading(timing: str) -> threading.Thread:
    """The aligner's compiled recursion made ready (align/dtw.py `warm`: numba imported and its kernel read from the
    disk cache, once per process) on a thread of its own while the first window is recognised, so that timing that
    window's words does not wait for it. A failure here is left to the aligner's own call."""
    def load() -> None:
        if timing != "whisper":
            with contextlib.suppress(Exception):
                warm()

    thread = threading.Thread(target=load, name="gesturelsm-aligner-ready", daemon=True)
    thread.start()
    return thread


def _piece(y: np.ndarray, a: int, b: int, words: list[Word], logp: float, ntok: int, details: dict, timing: str,
           last: bool) -> Piece:
    """Window y[a:b]'s recognised words timed on its audio, in seconds from the start of `y`."""
    chunk = y[a:b]
    heard = " ".join(w.text for w in words)
    timed, method, warnings = _timed(chunk, words, heard, timing) if words else ([], "none", [])
    t0, length = a / SAMPLE_RATE, (b - a) / SAMPLE_RATE
    timed = [Word(w.text, t0 + min(w.start, length), t0 + min(max(w.end, w.start), length)) for w in timed]
    return Piece(timed, math.inf if last else b / SAMPLE_RATE, heard, logp, ntok, method, warnings, details)


def english_transcript(pieces: list[Piece]) -> Transcript:
    """The English model's transcript of `y` from all its pieces: rejected (details["not_english"]) when every window
    loops or the pooled mean token log-probability is below MIN_AVG_LOGPROB, (details["no_words"]) with no words."""
    words = [w for p in pieces for w in p.words]
    heard = " ".join(p.heard for p in pieces if p.heard)
    logp, ntok = sum(p.logp for p in pieces), sum(p.ntok for p in pieces)
    avg = logp / ntok if ntok else -math.inf
    probs = [q for p in pieces for q in p.details.get("word_probabilities", [])]
    details = {"model": MODEL_NAME, "mean_word_probability": float(np.mean(probs)) if probs else 0.0,
               "max_no_speech_probability": max((p.details["max_no_speech_probability"] for p in pieces),
                                                default=1.0), "avg_logprob": avg, "windows": len(pieces)}
    conf = math.exp(avg) if words else 0.0
    if pieces and all(p.details.get("repeated_phrase") for p in pieces):
        phrase = pieces[0].details["heard_repeated"]
        details.update(not_english=True, repeated_phrase=True, heard_repeated=phrase)
        return _rejected(f"Automatic transcription was rejected: the English speech recogniser only heard one phrase "
                         f"over and over (\"{phrase}\"). The speech may not be English, or it is music, tones or "
                         "noise.", phrase, 0.0, details)
    if not words:
        details["no_words"] = True
        return _rejected("No speech was recognised (silence, noise or music?).", details=details)
    if avg < MIN_AVG_LOGPROB:
        details["not_english"] = True
        return _rejected(f"Automatic transcription was rejected: the English speech recogniser is unsure of what it "
                         f"heard (confidence {conf:.2f}; it heard \"{_clip(heard)}\"). The speech may not be English, "
                         "or it is noise or music.", heard, conf, details)
    methods = {p.timing_method for p in pieces if p.words}
    warnings = list(dict.fromkeys(w for p in pieces for w in p.warnings))
    return Transcript(words, heard, "en", None, "dtw" if methods == {"dtw"} else "whisper", warnings, True, conf,
                      heard, details)


def transcribe(audio: np.ndarray, timing: str = "auto", beam_size: int = BEAM_SIZE, language: str = AUTO,
               on_piece: Callable[[Piece], None] | None = None) -> Transcript:
    """Recognise `audio` ((N,) float32, 16 kHz) and time its words. Raises RecognizerUnavailable when
    faster-whisper or the weights are not installed; every other outcome is a Transcript (see its doc).

    language: AUTO (English first; where the English model rejects the speech as unsure or looping, or hears no words,
    the multilingual model identifies the language and transcribes it), ENGLISH (the English model only) or a Whisper
    code from languages.LANGUAGES (the multilingual model in that language, nothing identified). `on_piece`: called
    with each recognition window's English words as soon as they are timed (the pipelined generation's words)."""
    if timing not in TIMINGS:
        raise ValueError(f"timing must be one of {TIMINGS} (got {timing!r})")
    if language not in CHOICES:
        raise ValueError(f"language must be one of {', '.join(CHOICES)} (got {language!r})")
    y = np.asarray(audio, np.float32).reshape(-1)
    if len(y) < MIN_SECONDS * SAMPLE_RATE or not np.isfinite(y).all() or np.abs(y).max() < 1e-4:
        return _rejected("The audio is too short, silent or invalid: there is no speech to recognise.")
    if language not in (AUTO, ENGLISH):
        return _other_language(y, language, None, timing, beam_size)
    tr = _english(y, timing, beam_size, *([on_piece] if on_piece else []))
    if language == ENGLISH or tr.accepted or not (tr.details.get("not_english") or tr.details.get("no_words")):
        return tr
    return _identified(y, tr, timing, beam_size)


def _english(y: np.ndarray, timing: str, beam_size: int, on_piece: Callable[[Piece], None] | None = None) -> Transcript:
    """The English model's transcript, recognised and timed window by window (`english_pieces`, pooled by
    `english_transcript`); details["not_english"] where it was rejected as unsure or looping, the rejections another
    language explains, details["no_words"] where it heard nothing (another language is then identified only when the
    multilingual model is sure of it)."""
    pieces = []
    for piece in english_pieces(y, timing, beam_size):
        pieces.append(piece)
        if on_piece:
            on_piece(piece)
    return english_transcript(pieces)


def _identified(y: np.ndarray, english: Transcript, timing: str, beam_size: int) -> Transcript:
    """The English model rejected `y`: the multilingual model identifies its language and transcribes it. English
    again, or no language it is sure of, keeps the English model's rejection (with what was identified)."""
    lang, prob, _ = multilingual.load_model().detect_language(np.ascontiguousarray(y, np.float32))
    details = {**english.details, "identified": lang, "identified_probability": float(prob)}
    if english.details.get("no_words") and (lang == ENGLISH or prob < MIN_LANGUAGE_PROBABILITY_NO_WORDS):
        return replace(english, details=details)              # silence, noise, music: the English model's verdict
    if lang == ENGLISH or lang not in CHOICES or prob < MIN_LANGUAGE_PROBABILITY:
        why = (f" The multilingual recogniser heard English too (probability {prob:.2f})." if lang == ENGLISH else
               f" The multilingual recogniser could not tell the language (at best {name(lang)}, probability "
               f"{prob:.2f}); choose it to transcribe it anyway.")
        message = english.warnings[0].removesuffix(AUDIO_ONLY_NOTE) + why + AUDIO_ONLY_NOTE
        return Transcript([], "", "unknown", None, "none", [message], False, english.confidence, english.heard,
                          details)
    return _other_language(y, lang, float(prob), timing, beam_size)


def _other_language(y: np.ndarray, lang: str, prob: float | None, timing: str, beam_size: int) -> Transcript:
    """`y` transcribed in `lang` by the multilingual model; the recogniser's own word times (`timing` "dtw": our
    aligner with the language's eSpeak voice, where eSpeak reads it)."""
    words, avg, details = recognize(y, beam_size, multilingual.load_model(), lang)
    heard = ("" if lang in NO_SPACES else " ").join(w.text for w in words)
    conf = math.exp(avg) if words else 0.0
    details.update(avg_logprob=avg, language_name=name(lang))
    said = f"the speech recogniser ({name(lang)})"
    if details.get("repeated_phrase"):
        return _rejected(f"Automatic transcription was rejected: {said} only heard one phrase over and over "
                         f"(\"{details['heard_repeated']}\"): music, tones or noise?", details["heard_repeated"], 0.0,
                         details)
    if not words:
        return _rejected("No speech was recognised (silence, noise or music?).", details=details)
    if avg < MIN_AVG_LOGPROB_OTHER:
        return _rejected(f"Automatic transcription was rejected: {said} is unsure of what it heard (confidence "
                         f"{conf:.2f}; it heard \"{_clip(heard)}\").", heard, conf, details)
    voice = espeak_voice(lang)
    if timing == "dtw" and voice is not None:
        res = align_words(y, heard, AlignConfig.for_language(voice))
        return Transcript(res.words, heard, lang, prob, "dtw", [res.warning] if res.warning else [], True, conf,
                          heard, details)
    return Transcript(inside_speech(words, y), heard, lang, prob, "whisper", [], True, conf, heard, details)


def inside_speech(words: list[Word], y: np.ndarray) -> list[Word]:
    """Whisper's word times with each start moved out of a pause to where speech resumes (its first word often
    starts at 0.0 s, in the silence before the speech), never past the word's end or the next word's start."""
    act = voice_activity(y)
    segs = act.segments()
    if not segs or not words:
        return words
    starts = frame_time(np.array([s for s, _ in segs]))
    ends = frame_time(np.array([e for _, e in segs]))
    out = []
    for k, w in enumerate(words):
        n = int(np.searchsorted(starts, w.start, side="right"))   # voiced runs starting at or before w.start
        start = w.start
        if (n == 0 or w.start >= ends[n - 1]) and n < len(starts):  # in a pause: the next run starts the word
            start = min(float(starts[n]), w.end - 0.01)
        out.append(Word(w.text, max(start, w.start), w.end))
    return sequential(out)


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


__all__ = ["Transcript", "Piece", "RecognizerUnavailable", "recognize", "sequential", "transcribe", "english_pieces",
           "english_transcript", "MIN_AVG_LOGPROB"]
