"""Transcript -> word timings without a forced aligner: DTW against synthetic speech of the transcript.

Method (the aeneas idea, made robust): the transcript is normalised and spoken by eSpeak NG with a few
voices, so the word onsets in each synthetic clip are known. Long pauses are cut out of both clips (voice
activity), MFCCs of both are matched with a slope-constrained, open-ended DTW (music, noise or untranscribed
speech at either end is skipped at a fixed cost), and each synthetic onset is mapped through the path.
The median over voices is the estimate; onsets that land in a pause move to where the speech resumes.

Confidence compares the path cost with the cost of matching the same audio against the time-reversed
synthetic speech (same sounds, wrong order): 1 means far better than chance, 0 no better. Below
`min_confidence`, and when the transcript cannot fit the audio, the words are spread over the voiced time
in proportion to their length instead (method "even"), with a warning.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import tts
from .dtw import downsample, multiscale_dtw
from .features import FRAME_RATE, Activity, frame_time, mfcc_rows, voice_activity
from .normalize import Token, tokenize
from .words import AlignmentResult, Word


@dataclass(frozen=True)
class AlignConfig:
    voices: tuple[str, ...] = ("en-us+klatt", "en-us+m7", "en-us+f3")
    rate_wpm: int = 175
    pause_s: float = 0.25          # pauses longer than this are cut out before DTW ...
    margin_s: float = 0.06         # ... keeping this much silence on each side
    skip_cost: float = 0.9         # cost per skipped frame at the ends (cosine distance units)
    gap_cost: float | None = None  # cost per frame matched to nothing inside (None: not allowed)
    min_confidence: float = 0.25
    max_speed: float = 3.5         # the transcript needs at most this x the synthetic time to fit
    min_word_s: float = 0.02


DEFAULT = AlignConfig()
SAMPLE_RATE = 16_000
CONFIDENCE_SCALE = 0.3  # relative cost gain over the reversed-speech baseline that counts as certain
MIN_AUDIO_S = 0.3


def align_words(audio: np.ndarray, text: str, config: AlignConfig = DEFAULT) -> AlignmentResult:
    """Word timings for `text` spoken in `audio` ((N,) float32 mono at 16 kHz). Never raises for bad
    input: empty text gives method "audio-only", silence or unusable audio gives "even" with a warning."""
    audio = np.nan_to_num(np.asarray(audio, np.float32).reshape(-1))
    tokens = tokenize(text or "")
    duration = len(audio) / SAMPLE_RATE
    if not tokens:
        return AlignmentResult([], 0.0, "audio-only", "The transcript has no words: using the audio only.")
    if duration < MIN_AUDIO_S:
        return _even(tokens, None, duration, f"The audio is too short to align ({duration:.2f} s).")
    act = voice_activity(audio)
    if not act.voiced.any():
        return _even(tokens, act, duration, "No speech found in the audio (silence?): words spread evenly.")
    try:
        onsets, conf, speed = _dtw_onsets(audio, tokens, act, config)
    except tts.TTSUnavailable as exc:
        return _even(tokens, act, duration, f"{exc}; words spread evenly over the speech instead.")
    if speed > config.max_speed:
        return _even(tokens, act, duration, f"The transcript is much longer than the speech ({len(tokens)} "
                     f"words would need {speed:.1f}x normal speed): words spread evenly, check the text.")
    if conf < config.min_confidence:
        return _even(tokens, act, duration, f"Low alignment confidence ({conf:.2f}): does the transcript match "
                     "the audio? Words spread evenly over the speech instead.", conf)
    words = _intervals(tokens, onsets, act, duration, config.min_word_s)
    return AlignmentResult(words, conf, "dtw", None, {"speed": speed})


def _dtw_onsets(audio: np.ndarray, tokens: list[Token], act: Activity, config: AlignConfig,
                ) -> tuple[np.ndarray, float, float]:
    """(W,) onsets in seconds (median over voices), confidence, needed speed-up of the transcript."""
    keep_real = _keep_frames(act, config)
    B = mfcc_rows(audio)[keep_real]
    estimates, confs, speeds = [], [], []
    for voice in config.voices:
        syn = tts.synthesize([t.spoken for t in tokens], voice, config.rate_wpm)
        keep_syn = _keep_frames(voice_activity(syn.audio, syn.sr), config)
        A = mfcc_rows(syn.audio, syn.sr)[keep_syn]
        speeds.append(len(A) / max(len(B), 1))
        path, _ = multiscale_dtw(A, B, config.skip_cost, config.gap_cost)
        confs.append(_confidence(A, B, config.skip_cost))
        on_syn = np.searchsorted(keep_syn, np.round(syn.starts * FRAME_RATE))  # compressed synth frames
        first = np.full(len(A), -1, np.int64)
        for i, j in path[::-1]:
            first[i] = j
        first = _fill_forward(first, len(B))
        estimates.append(frame_time(keep_real[first[np.clip(on_syn, 0, len(A) - 1)]]))
    onsets = np.median(np.array(estimates), axis=0)
    return _snap_to_speech(np.maximum.accumulate(onsets), act), float(np.median(confs)), float(np.median(speeds))


def _confidence(A: np.ndarray, B: np.ndarray, skip_cost: float, factor: int = 4) -> float:
    """0..1: how much better the coarse DTW cost is than matching against the reversed synthetic speech."""
    Ac, Bc = downsample(A, factor), downsample(B, factor)
    _, cost = multiscale_dtw(Ac, Bc, skip_cost)
    _, null = multiscale_dtw(Ac[::-1].copy(), Bc, skip_cost)
    return float(np.clip((null - cost) / max(null, 1e-6) / CONFIDENCE_SCALE, 0.0, 1.0))


def _keep_frames(act: Activity, config: AlignConfig) -> np.ndarray:
    """Indices of frames kept for DTW: everything except the inside of pauses longer than `pause_s`."""
    keep = np.ones(len(act.voiced), bool)
    margin, min_pause = int(round(config.margin_s * FRAME_RATE)), int(round(config.pause_s * FRAME_RATE))
    segs = act.segments()
    gaps = [(0, segs[0][0])] + [(a[1], b[0]) for a, b in zip(segs, segs[1:])] + [(segs[-1][1], len(keep))]
    for s, e in gaps:
        if e - s > min_pause:
            keep[s + (margin if s > 0 else 0): e - (margin if e < len(keep) else 0)] = False
    return np.nonzero(keep)[0]


def _fill_forward(first: np.ndarray, m: int) -> np.ndarray:
    """Rows the path did not visit (skipped at the ends) take the nearest visited row's column."""
    idx = np.nonzero(first >= 0)[0]
    if len(idx) == 0:
        return np.zeros_like(first)
    return first[idx[np.clip(np.searchsorted(idx, np.arange(len(first))), 0, len(idx) - 1)]]


def _snap_to_speech(onsets: np.ndarray, act: Activity) -> np.ndarray:
    """An onset inside a pause moves to the end of that pause (words start where speech starts)."""
    segs = act.segments()
    starts = frame_time(np.array([s for s, _ in segs]))
    ends = frame_time(np.array([e for _, e in segs]))
    out = onsets.copy()
    for k, t in enumerate(onsets):
        n = int(np.searchsorted(starts, t, side="right"))  # first voiced run starting after t
        in_pause = n == 0 or t >= ends[n - 1]
        if in_pause and n < len(starts):
            out[k] = starts[n]
    return np.maximum.accumulate(out)


def _intervals(tokens: list[Token], onsets: np.ndarray, act: Activity | None, duration: float,
               min_word_s: float) -> list[Word]:
    """Words from onsets: each ends at the next onset or where speech stops before it; at least
    `min_word_s` long where the audio allows; all inside [0, duration]."""
    n = len(tokens)
    starts = np.maximum.accumulate(np.clip(onsets, 0.0, duration))
    for k in range(1, n):  # keep at least min_word_s between onsets where there is room
        starts[k] = max(starts[k], starts[k - 1] + min_word_s)
    starts = np.minimum(starts, duration - min_word_s * (n - np.arange(n)))
    starts = np.clip(starts, 0.0, duration)
    nxt = np.append(starts[1:], duration)
    ends = nxt.copy()
    if act is not None:
        voiced_end = _speech_end_after(starts, act, duration)
        ends = np.minimum(nxt, np.maximum(voiced_end, starts + min_word_s))
    ends = np.maximum(ends, np.minimum(starts + 1e-3, duration))
    return [Word(t.text, float(s), float(e)) for t, s, e in zip(tokens, starts, ends)]


def _speech_end_after(starts: np.ndarray, act: Activity, duration: float) -> np.ndarray:
    """For each onset, the end of the voiced run it falls in (or the next one)."""
    segs = act.segments()
    if not segs:
        return np.full(len(starts), duration)
    ends = frame_time(np.array([e for _, e in segs]))
    k = np.clip(np.searchsorted(ends, starts, side="right"), 0, len(ends) - 1)
    return np.minimum(ends[k], duration)


def _even(tokens: list[Token], act: Activity | None, duration: float, warning: str,
          confidence: float = 0.0) -> AlignmentResult:
    """Fallback: words spread over the voiced time (or the whole clip) in proportion to their length."""
    onsets = even_onsets([t.spoken for t in tokens], act, duration)
    words = _intervals(tokens, onsets, act, duration, 0.02)
    return AlignmentResult(words, confidence, "even", warning)


def even_onsets(spoken: list[str], act: Activity | None, duration: float) -> np.ndarray:
    """Onsets that split the voiced time (all of it when `act` is None or silent) by letter count."""
    weights = np.array([max(len(s.replace(" ", "")), 1) for s in spoken], float)
    cum = np.concatenate([[0.0], np.cumsum(weights)[:-1]]) / weights.sum()
    if act is None or not act.voiced.any():
        return cum * duration
    t = frame_time(np.nonzero(act.voiced)[0])  # voiced frame times, in order
    pos = np.clip((cum * len(t)).astype(int), 0, len(t) - 1)
    return t[pos]
