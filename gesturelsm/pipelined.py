"""Speech preparation pipelined with generation: the automatic words of a speech are recognised and timed
window by window on a thread (asr/recognition_windows.py, asr/transcribe.py `english_pieces`), their text features built
as they come (features/text.py `WordFeatureStream`: bounded look-ahead), and generation conditions each of its windows
as soon as the words it reads are final, while later speech is still being recognised.

The pipelined and the one-shot path compute the same numbers: the same recognition windows (cut by the samples
alone), the same word features (bit for bit), the same grouping of generation windows (`ready_points`: the frames at
which each recognition window makes the features final, used by both). Where the finished transcript is not the
English words that were streamed (rejected as not English or unsure, another language identified, the recogniser not
installed), `PendingWords.wait` raises `Restart` and the pipeline generates again from the finished speech, exactly as
the one-shot path would have.
"""
from __future__ import annotations

import math
import threading
import time
from dataclasses import replace

import numpy as np
import torch

from .asr.languages import AUTO, ENGLISH
from .asr.source import AutomaticWords, automatic_words
from .asr.transcribe import Piece
from .asr.recognition_windows import recognition_cuts
from .backends import SpeechInput
from .constants import FPS, SAMPLE_RATE
from .features.text import TEXT_DIM, TextEmbedder, WordFeatureStream, features_final_until
from .motion.sequence import MotionSequence
from .settings import PostProcess

STREAMED_LANGUAGES = (AUTO, ENGLISH)        # the English model runs window by window; others recognise whole speech
PENDING_MODE = "automatic transcript (being recognised)"


WAITING, HIDDEN = "waiting for words", "transcription hidden"
# torch's math threads on the words thread (the recogniser keeps its own): generation works on the other thread, and
# two math threads each on two cores cost more than they give (benchmarks/cli_words.py, docs/BENCHMARKS.md)
WORDS_THREADS = 1


def overlap_timings(pending: "PendingWords", started: float, timings: dict[str, float], again: bool = False
                    ) -> dict[str, float]:
    """Pipelined speech: how long generation (started at `started`, perf_counter) waited for words, taken out of its
    sampling time, and how much of the transcription ran while generation worked (hidden under it). `again`: the
    motion was made again on the finished speech (pipelined.Restart): its sampling time is its own, nothing hidden."""
    if again:
        return {WAITING: pending.waited, HIDDEN: 0.0}
    before = max(0.0, started - pending.started)                 # the words thread ran alone before generation
    hidden = max(0.0, min(pending.transcription_s, pending.transcription_s + pending.text_seconds - pending.waited
                          - before))
    return {"sampling": max(0.0, timings.get("sampling", 0.0) - pending.waited), WAITING: pending.waited,
            HIDDEN: hidden}


OUTPUTS = ("finished", "raw")       # what `GesturePipeline.generate` returns: post-processed, or as sampled


def finished(motion: MotionSequence, speech: "SpeechInput", post: PostProcess,
             body=None) -> tuple[MotionSequence, str | None]:
    """`motion` as every entry point shows it: fitted to the speech's length, post-processed (`post` on `body`)
    and keeping the words it was made from; and why grounding had to leave it as it was, when it had to."""
    motion, note = post.apply(motion.slice(0, speech.num_frames), body)
    return with_speech(motion, speech), note


def with_speech(motion: MotionSequence, speech: "SpeechInput") -> MotionSequence:
    """`motion` keeping the transcript and word timings it was made from (saved in its npz: `transcript`, `words`,
    `word_times`; `gesturelsm edit` reuses them); none for audio-only speech."""
    words = tuple((w.text, float(w.start), float(w.end)) for w in speech.words or ())
    transcript = speech.transcript or (" ".join(w for w, _, _ in words) or None)
    return replace(motion, transcript=transcript, words=words)


def finish(seq: MotionSequence, stand_in_place: bool = False, smoothing: str = "off", grounding: bool = False,
           body=None) -> tuple[MotionSequence, str | None]:
    """`seq` post-processed with these options (`settings.PostProcess.apply`: stand in place, smoothing, feet on the
    ground on `body`), and why grounding had to leave it as it was, when it had to."""
    return PostProcess(stand_in_place, smoothing, grounding).apply(seq, body)


class Restart(Exception):
    """The streamed words are not the finished transcript's: generate again from `PendingWords.settle()`."""


def windowed_ready_points(y: np.ndarray, num_frames: int) -> tuple[int, ...]:
    """The frame counts at which each recognition window of `y` makes the word features final (the last: all)."""
    cuts = recognition_cuts(y)
    out = [min(num_frames, math.ceil(features_final_until(c / SAMPLE_RATE) * FPS)) for c in cuts[1:-1]]
    return tuple(out) + (num_frames,)


def ready_points_of(auto: AutomaticWords, y: np.ndarray, num_frames: int) -> tuple[int, ...]:
    """`windowed_ready_points` for words the English model recognised window by window; () for any other words."""
    tr = auto.transcript
    windowed = auto.words and getattr(tr, "language", None) == ENGLISH and getattr(tr, "details", {}).get("windows")
    return windowed_ready_points(y, num_frames) if windowed else ()


def with_words(speech: SpeechInput, words: list | None, mode: str, transcript: str | None = None,
               warnings: list[str] = (), ready_points: tuple[int, ...] = ()) -> SpeechInput:
    """`speech` (audio features ready) conditioned on `words` (None: audio-only): their bounded-context text features
    (timed into "features"); the text encoder missing: audio-only with a warning."""
    timings, warnings = dict(speech.timings), list(speech.warnings) + list(warnings)
    T = speech.num_frames
    wf, hw = torch.zeros(T, TEXT_DIM), torch.zeros(T, dtype=torch.bool)
    if words:
        emb = TextEmbedder.shared()
        if emb.available:             # loads the encoder, or waits for the thread loading it: not feature time
            t0 = time.perf_counter()
            ft = emb.frame_features(words, T)
            wf, hw = torch.from_numpy(ft.features), torch.from_numpy(ft.has_word)
            timings["features"] = timings.get("features", 0.0) + time.perf_counter() - t0
        else:
            warnings.append(f"{emb.error}; generating from audio only")
            words, mode = None, "audio-only (text encoder unavailable)"
    return replace(speech, words=words or None, word_features=wf, has_word=hw, text_mode=mode, timings=timings,
                   warnings=warnings, transcript=transcript if words else None,
                   ready_points=ready_points if words else (), stream=None)


def automatic_speech(speech: SpeechInput, auto: AutomaticWords, transcription_s: float) -> SpeechInput:
    """`speech` with the automatic words `auto` (one-shot and pipelined alike); `transcription_s`: the seconds this
    call waited for them (words recognised earlier keep the time their recognition took then, marked `earlier`)."""
    transcript = auto.transcript.text if auto.transcript is not None and auto.words else None
    speech = replace(speech, timings={**speech.timings, "transcription": recognition_seconds(auto, transcription_s)},
                     earlier=("transcription",) if auto.earlier else ())
    return with_words(speech, auto.words, auto.text_mode, transcript, auto.warnings,
                      ready_points_of(auto, speech.audio, speech.num_frames))


def recognition_seconds(auto: AutomaticWords, waited: float) -> float:
    """The transcription stage's time: what recognising `auto` took when it ran earlier, else the `waited` seconds."""
    return auto.seconds if auto.earlier and auto.seconds > 0 else waited


class PendingWords:
    """The automatic words of one speech, recognised on a thread and made into word features as they come: the
    `stream` of a SpeechInput (`start`). Generation calls `wait(n)`; the pipeline calls `settle()` for the finished
    speech and reads `valid` (the streamed words are its words) and the seconds it waited (`waited`)."""

    def __init__(self, speech: SpeechInput, language: str, recognise=automatic_words, progress=None):
        self.base, self.language, self.recognise, self.progress = speech, language, recognise, progress
        self.features = WordFeatureStream(TextEmbedder.shared(), speech.num_frames)
        self.ready_points = windowed_ready_points(speech.audio, speech.num_frames)
        self._cond = threading.Condition()
        self._ready, self._done = 0, False
        self._final: SpeechInput | None = None
        self._error: BaseException | None = None
        self.valid = False
        self.waited = 0.0
        self.text_seconds = 0.0
        self.started = time.perf_counter()
        self.transcription_s = 0.0
        self._no_encoder = False
        self.encoder_wait = 0.0           # the words thread's wait for the text encoder to load (not transcription)
        self._attached = threading.Event()
        self._thread = threading.Thread(target=self._run, name="gesturelsm-words", daemon=True)

    @classmethod
    def start(cls, speech: SpeechInput, language: str, recognise=automatic_words, progress=None) -> SpeechInput:
        """`speech` (audio features ready) with its words being recognised on a thread started by this call, by
        `recognise` (asr.source.automatic_words or a stand-in with its signature); `progress` hears "speech
        transcribed"."""
        return cls.begin(speech, language, recognise, progress).attach(speech)

    @classmethod
    def begin(cls, speech: SpeechInput, language: str, recognise=automatic_words, progress=None) -> "PendingWords":
        """The recognition of `speech`'s audio started before its audio features are computed (they are not read until
        the words are known): `attach` the speech with its features to get the streamed speech."""
        pending = cls(speech, language, recognise, progress)
        pending._thread.start()
        return pending

    def attach(self, speech: SpeechInput) -> SpeechInput:
        """`speech` (the same audio, its audio features ready) streamed: its word features fill in as they come."""
        self.base = speech
        self._attached.set()
        return replace(speech, words=[], word_features=torch.from_numpy(self.features.features),
                       has_word=torch.from_numpy(self.features.has_word), text_mode=PENDING_MODE,
                       ready_points=self.ready_points, stream=self)

    def abandon(self) -> None:
        """No speech will be attached (preparing its audio features failed): the thread ends once the words are in."""
        self.base = None
        self._attached.set()

    def _piece(self, piece: Piece) -> None:
        t0 = time.perf_counter()
        if self._no_encoder or not self.features.embedder.available:   # loads it, or waits for its loading
            self._no_encoder = True       # the words are recognised on; the finished speech says why audio-only
            return
        self.encoder_wait += time.perf_counter() - t0
        t0 = time.perf_counter()
        self.features.extend(piece.words, piece.final_until)
        self.text_seconds += time.perf_counter() - t0
        with self._cond:
            self._ready = self.features.ready_frames()
            self._cond.notify_all()

    def _run(self) -> None:
        threads = torch.get_num_threads()
        torch.set_num_threads(WORDS_THREADS)          # the text encoder here: generation has the other core
        try:
            auto = self.recognise(self.base.audio, language=self.language, on_piece=self._piece)
            self.transcription_s = time.perf_counter() - self.started - self.text_seconds - self.encoder_wait
            self._attached.wait()                     # the speech with its audio features, which the result keeps
            if self.base is None:
                return
            streamed = list(self.features.words)
            if auto.words and not streamed and not self._no_encoder and \
                    ready_points_of(auto, self.base.audio, self.base.num_frames):
                self._piece(Piece(list(auto.words), math.inf, "", 0.0, 0, "", [], {}))   # remembered: all at once
                streamed = list(auto.words)
            self.valid = bool(auto.words) and not self._no_encoder and streamed == list(auto.words) and \
                ready_points_of(auto, self.base.audio, self.base.num_frames) == self.ready_points
            if self.valid:
                transcript = auto.transcript.text if auto.transcript is not None else None
                base = replace(self.base, timings={**self.base.timings,
                                                   "transcription": recognition_seconds(auto, self.transcription_s),
                                                   "features": self.base.timings.get("features", 0.0)
                                                   + self.text_seconds},
                               earlier=("transcription",) if auto.earlier else ())
                self._final = replace(base, words=list(auto.words), word_features=torch.from_numpy(
                    self.features.features.copy()), has_word=torch.from_numpy(self.features.has_word.copy()),
                    text_mode=auto.text_mode, warnings=list(base.warnings) + list(auto.warnings),
                    transcript=transcript, ready_points=self.ready_points, stream=None)
            else:
                self._final = automatic_speech(self.base, auto, self.transcription_s)
            if self.progress:
                self.progress(0.2, "speech transcribed")
        except BaseException as exc:  # handed to the generating thread
            self._error = exc
        finally:
            torch.set_num_threads(threads)
            with self._cond:
                self._done = True
                self._cond.notify_all()

    def wait(self, frames: int) -> None:
        t0 = time.perf_counter()
        with self._cond:
            while self._ready < frames and not self._done:
                self._cond.wait()
        self.waited += time.perf_counter() - t0
        if self._error is not None:
            raise self._error
        if self._done and not self.valid:
            raise Restart()

    @property
    def error(self) -> BaseException | None:
        """What the words thread raised (None: nothing, or not finished)."""
        return self._error

    @property
    def done(self) -> bool:
        """The words are finished (settle() returns at once)."""
        return self._done

    def settle(self) -> SpeechInput:
        """The finished speech (waits for the words); the thread's error, if it failed."""
        self._thread.join()
        if self._error is not None:
            raise self._error
        return self._final


__all__ = ["HIDDEN", "OUTPUTS", "WAITING", "finish", "finished", "overlap_timings", "with_speech", "PendingWords",
           "Restart", "automatic_speech", "ready_points_of", "windowed_ready_points", "with_words",
           "STREAMED_LANGUAGES"]
