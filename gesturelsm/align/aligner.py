"""Transcript -> word timings without a forced aligner: DTW against synthetic speech of the transcript.

Method (the aeneas idea, made robust): the transcript is normalised and spoken by eSpeak NG in three voices,
so the word onsets in each synthetic clip are known. Pauses longer than `pause_s` are cut out of both clips
(voice activity); MFCCs are matched with a slope-constrained DTW (local tempo ratio 1/3..3) whose ends are
open (music, noise or untranscribed speech before or after is skipped at `skip_cost` per frame) and which
may leave frames unmatched inside at `gap_cost` (fillers, words not spoken). Each synthetic onset is mapped
through the path; the median over voices is the estimate; an onset inside a pause moves to where speech
resumes. Times are seconds from the first sample; audio is 16 kHz mono float32.

Confidence (0..1) compares the mean frame distance along the path with that along the path found for the
synthetic words in reverse order (same sounds, wrong sequence). When it is below `min_confidence`, when the
transcript cannot fit the speech, or when eSpeak NG is missing, the words are spread over the voiced time in
proportion to their length (method "even") and the result carries a warning saying why.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import tts
from ..constants import SAMPLE_RATE
from .dtw import downsample, multiscale_dtw
from .features import FRAME_RATE, Activity, flip_short_runs, frame_time, mfcc_rows, voice_activity
from .normalize import Token, tokenize
from .words import AlignmentResult, Word

MIN_AUDIO_S = 0.3
CONFIDENCE_SCALE = 0.12  # relative distance gain over the word-reversed baseline that counts as certain
SNAP_EDGE_S = 0.1        # an onset this close before a long pause belongs after it
END_PAUSE_S = 0.15       # a word ends early only where the speech stops for at least this long


@dataclass(frozen=True)
class AlignConfig:
    voices: tuple[str, ...] = ("en-us+klatt", "en-us+m7", "en-us+f3")  # eSpeak NG voice+variant names
    language: str = "en"           # for text normalisation (numbers are written out in English only)
    rate_wpm: int = 175            # synthetic speaking rate
    pause_s: float = 0.25          # pauses longer than this are cut out before DTW ...
    margin_s: float = 0.06         # ... keeping this much silence on each side
    skip_cost: float = 0.9         # per frame skipped at either end (cosine-distance units)
    gap_cost: float | None = None  # per frame left unmatched inside (None: never; see `dtw`)
    min_confidence: float = 0.2
    max_speed: float = 3.5         # fall back when the transcript would need this x eSpeak's tempo
    warn_speed: float = 2.0        # warn (but align) above this
    warn_short: float = 0.3        # warn (but align) below this: the words fill under 30 % of the voiced speech at a
                                   # normal tempo (the BEAT2 takes' own transcripts measure 0.68-1.06, half of them
                                   # 0.34-0.52)
    min_word_s: float = 0.02       # onsets are at least this far apart where the audio allows

    @classmethod
    def for_language(cls, language: str | None) -> AlignConfig:
        """Default settings with eSpeak NG voices of `language` (e.g. "en-us", "en-gb", "de", "fr"); None: a language
        eSpeak does not read (Chinese, Japanese): no voices, the words are spread by length (method "even")."""
        if language is None:
            return cls(voices=(), language="")
        base = language.split("+")[0]
        return cls(voices=tuple(f"{base}+{v}" for v in ("klatt", "m7", "f3")), language=base.split("-")[0])


DEFAULT = AlignConfig()


def align_words(audio: np.ndarray, text: str, config: AlignConfig = DEFAULT) -> AlignmentResult:
    """Word timings for `text` spoken in `audio` ((N,) float32 mono, 16 kHz). One Word per transcript token,
    in order, with the token as written. Never raises for bad input: no words gives method "audio-only";
    silence, too-short audio or an unusable transcript give method "even" with a warning."""
    audio = np.nan_to_num(np.asarray(audio, np.float32).reshape(-1))
    tokens = tokenize(text or "", config.language)
    duration = len(audio) / SAMPLE_RATE
    if not tokens:
        return AlignmentResult([], 0.0, "audio-only", "The transcript has no words: using the audio only.")
    if duration < MIN_AUDIO_S:
        if duration == 0:
            return AlignmentResult([], 0.0, "audio-only", "The audio is empty: no words can be placed.")
        return _even(tokens, None, duration, f"The audio is too short to align ({duration:.2f} s): words "
                     "spread over it evenly.")
    act = voice_activity(audio)
    if not act.voiced.any():
        return _even(tokens, None, duration, "No speech found in the audio (silence?): words spread evenly.")
    if not config.voices:
        return _even(tokens, act, duration, "eSpeak NG does not read this language, so the typed words are spread over "
                     "the speech by length; leave the transcript empty to have the words recognised and timed.")
    try:
        syntheses = tts.synthesize([t.spoken for t in tokens], config.voices, config.rate_wpm)
    except tts.TTSUnavailable as exc:
        return _even(tokens, act, duration, f"{exc}. Words spread over the speech by length instead.")
    keep_real = _keep_frames(act, config)
    keep_syn = [_keep_frames(voice_activity(s.audio, s.sr), config) for s in syntheses]
    speed = float(np.median([len(k) for k in keep_syn])) / len(keep_real)
    if speed > config.max_speed:
        return _even(tokens, act, duration, f"The transcript is much longer than the speech ({len(tokens)} words "
                     f"would need {speed:.1f}x a normal tempo): words spread evenly; check the text.")
    try:
        onsets, conf = _dtw_onsets(audio, keep_real, act, syntheses, keep_syn, config)
    except ValueError as exc:  # no warping path (only without skip_cost); say so rather than fail
        return _even(tokens, act, duration, f"Alignment failed ({exc}): words spread over the speech by length.")
    if conf < config.min_confidence:
        why = short_transcript_warning(len(tokens), speed) + " " if speed < config.warn_short else \
            f"Low alignment confidence ({conf:.2f}): does the transcript match the audio? "
        return _even(tokens, act, duration, why + "Words spread over the speech by length instead.", conf)
    warning = None
    if speed > config.warn_speed:
        warning = (f"The transcript looks longer than the speech ({speed:.1f}x a normal tempo): words that are "
                   "not spoken get squeezed between their neighbours.")
    elif speed < config.warn_short:
        warning = short_transcript_warning(len(tokens), speed)
    return AlignmentResult(_intervals(tokens, onsets, act, duration, config.min_word_s), conf, "dtw", warning,
                           {"speed": speed, "voices": [s.voice for s in syntheses]})


def _dtw_onsets(audio: np.ndarray, keep_real: np.ndarray, act: Activity, syntheses: list[tts.Synthesis],
                keep_syn: list[np.ndarray], config: AlignConfig) -> tuple[np.ndarray, float]:
    """(W,) onsets in seconds (median over voices) and the median confidence. `keep_*`: the frames left
    after cutting long pauses, of the audio and of each synthetic clip."""
    B = mfcc_rows(audio, SAMPLE_RATE)[keep_real]
    estimates, confs = [], []
    for syn, keep in zip(syntheses, keep_syn):
        A = mfcc_rows(syn.audio, syn.sr)[keep]
        path, _ = multiscale_dtw(A, B, config.skip_cost, config.gap_cost)
        onset_rows = np.clip(np.searchsorted(keep, np.round(syn.starts * FRAME_RATE)), 0, len(A) - 1)
        confs.append(_confidence(A, B, onset_rows, config.skip_cost))
        first = np.full(len(A), -1, np.int64)  # first reference frame matched to each synthetic frame
        for i, j in path[::-1]:
            first[i] = j
        first = _fill_unmatched(first)
        estimates.append(frame_time(keep_real[first[onset_rows]]))
    onsets = np.maximum.accumulate(np.median(np.array(estimates), axis=0))
    return _snap_to_speech(onsets, act), float(np.median(confs))


def _confidence(A: np.ndarray, B: np.ndarray, onset_rows: np.ndarray, skip_cost: float, factor: int = 4,
                ) -> float:
    """0..1: how much closer the matched frames are on the (coarse) DTW path than on the path found for the
    same synthetic words spoken in reverse order (each word still forward: same sounds, wrong sequence).
    Frames skipped at the ends do not count, so a transcript of only part of the speech can be confident."""
    bounds = np.unique(np.concatenate([[0], onset_rows, [len(A)]]))
    shuffled = np.concatenate([A[a:b] for a, b in zip(bounds[:-1], bounds[1:])][::-1])
    costs = []
    for query in (downsample(A, factor), downsample(shuffled, factor)):
        Bc = downsample(B, factor)
        path, _ = multiscale_dtw(query, Bc, skip_cost)
        costs.append(float(np.mean(1.0 - np.sum(query[path[:, 0]] * Bc[path[:, 1]], axis=1))))
    cost, null = costs
    return float(np.clip((null - cost) / max(null, 1e-6) / CONFIDENCE_SCALE, 0.0, 1.0))


def _keep_frames(act: Activity, config: AlignConfig) -> np.ndarray:
    """Indices of the frames kept for DTW: all but the inside of pauses longer than `pause_s` (and of
    silence before the first and after the last voiced frame)."""
    n = len(act.voiced)
    keep = np.ones(n, bool)
    margin, min_pause = round(config.margin_s * FRAME_RATE), round(config.pause_s * FRAME_RATE)
    segs = act.segments()
    if not segs:
        return np.arange(n)
    gaps = [(0, segs[0][0])] + [(a[1], b[0]) for a, b in zip(segs, segs[1:])] + [(segs[-1][1], n)]
    for s, e in gaps:
        if e - s > min_pause:
            keep[s + (margin if s > 0 else 0): e - (margin if e < n else 0)] = False
    return np.nonzero(keep)[0]


def _fill_unmatched(first: np.ndarray) -> np.ndarray:
    """Rows the path never visits (skipped at the ends) take the nearest later (else earlier) visited row."""
    idx = np.nonzero(first >= 0)[0]
    if len(idx) == 0:
        return np.zeros_like(first)
    return first[idx[np.clip(np.searchsorted(idx, np.arange(len(first))), 0, len(idx) - 1)]]


def _snap_to_speech(onsets: np.ndarray, act: Activity, edge_s: float = SNAP_EDGE_S,
                    min_pause_s: float = 0.2) -> np.ndarray:
    """Words start where speech starts: an onset inside a pause, or less than `edge_s` before a pause of at
    least `min_pause_s` that lies before the next word's onset, moves to the end of that pause."""
    segs = act.segments()
    starts = frame_time(np.array([s for s, _ in segs]))
    ends = frame_time(np.array([e for _, e in segs]))
    nxt = np.append(onsets[1:], np.inf)
    out = onsets.copy()
    for k, t in enumerate(onsets):
        n = int(np.searchsorted(starts, t, side="right"))  # voiced runs starting at or before t
        if n >= len(starts):
            continue
        in_pause = n == 0 or t >= ends[n - 1]
        long_pause_ahead = n > 0 and ends[n - 1] - t < edge_s and starts[n] - ends[n - 1] >= min_pause_s
        if in_pause or (long_pause_ahead and starts[n] <= nxt[k]):
            out[k] = starts[n]
    return np.maximum.accumulate(out)


def _intervals(tokens: list[Token], onsets: np.ndarray, act: Activity | None, duration: float,
               min_word_s: float) -> list[Word]:
    """Words from onsets, all inside [0, duration] with start < end: onsets at least `min_word_s` apart
    (less when the clip is too short for that); each word ends at the next onset, or earlier where the
    speech stops in between."""
    n = len(tokens)
    step = min(min_word_s, duration / (n + 1))
    starts = np.maximum.accumulate(np.clip(np.asarray(onsets, float), 0.0, duration))
    for k in range(1, n):
        starts[k] = max(starts[k], starts[k - 1] + step)
    starts = np.minimum(starts, duration - step * (n - np.arange(n)))  # room for the words after
    nxt = np.append(starts[1:], duration)
    ends = nxt
    if act is not None and act.voiced.any():
        ends = np.minimum(nxt, np.maximum(_speech_end_after(starts, act), starts + step))
    return [Word(t.text, float(s), float(e)) for t, s, e in zip(tokens, starts, ends)]


def _speech_end_after(starts: np.ndarray, act: Activity, min_pause_s: float = END_PAUSE_S) -> np.ndarray:
    """For each onset, where speech next stops for at least `min_pause_s` (s); shorter dips (stop closures)
    do not end a word."""
    voiced = flip_short_runs(act.voiced, False, round(min_pause_s * FRAME_RATE))
    ends = frame_time(np.array([e for _, e in Activity(voiced, act.floor_db, act.speech_db).segments()]))
    return ends[np.clip(np.searchsorted(ends, starts, side="right"), 0, len(ends) - 1)]


def short_transcript_warning(words: int, speed: float) -> str:
    return (f"The transcript looks far too short for the speech: its {words} words would fill about {speed:.0%} of "
            "it at a normal tempo, so the speech they do not name gets no words. Give the whole transcript, or leave "
            "it empty to have the speech transcribed.")


def _even(tokens: list[Token], act: Activity | None, duration: float, warning: str,
          confidence: float = 0.0) -> AlignmentResult:
    """Fallback: words spread over the voiced time (or the whole clip) in proportion to their length."""
    onsets = even_onsets([t.spoken for t in tokens], act, duration)
    return AlignmentResult(_intervals(tokens, onsets, act, duration, 0.02), confidence, "even", warning)


def even_onsets(spoken: list[str], act: Activity | None, duration: float) -> np.ndarray:
    """Onsets that split the voiced time (the whole clip when `act` is None) in proportion to letter count."""
    weights = np.array([max(len(s.replace(" ", "")), 1) for s in spoken], float)
    cum = np.concatenate([[0.0], np.cumsum(weights)[:-1]]) / weights.sum()
    if act is None or not act.voiced.any():
        return cum * duration
    t = frame_time(np.nonzero(act.voiced)[0])  # voiced frame times, in order
    return t[np.clip((cum * len(t)).astype(int), 0, len(t) - 1)]

