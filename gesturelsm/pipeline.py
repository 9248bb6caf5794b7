"""The one pure-Python entry point: speech (+ transcript) -> SMPL-X motion. The app, the CLI, the
benchmarks and the tests all call this.

    pipe = GesturePipeline.from_pretrained()            # shipped checkpoints in assets/
    res = pipe.generate(audio, sr, text="hello there", steps=8, cfg=2.0, seed=0, method="gesturelsm")
    res.motion.save("out.npz")                          # BEAT2 npz, 30 fps: what `gesturelsm generate` writes
    res = pipe.generate(audio, sr, settings=Settings(seed=3, post=PostProcess(grounding=False)))   # or one object
    ed = pipe.edit(res.motion, audio, {"upper": [(3.0, 6.0)]}, seed=1)   # regenerate the upper body over 3-6 s
    for ev in pipe.stream(audio, sr, settings=Settings(methods=("gesturelsm", "ddim"))):   # as it is made:
        print(ev.method, ev.frames if isinstance(ev, Window) else "made")       # windows (raw), then each Made

Every method is a backend (`gesturelsm.backends`): the pipeline prepares the speech once, checks the settings
against the method's spec with the one validator (`gesturelsm.settings`) and calls the backend's `generate`.
"""
from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path
from typing import Iterator, Mapping, Sequence

import numpy as np
import torch

from .align import align_words
from .asr.languages import AUTO, NOT_FOR_GESTURES, gesture_words
from .asr.source import AutomaticWords, automatic_words, remember_words, typed_alignment
from .audio import SAMPLE_RATE, resample, to_mono
from .backends import (GROUND_TRUTH, Backend, Bounds, FlowBackend, MethodSpec, SpeechInput, flow_backends,
                       load_backends)
from .constants import ASSETS, Progress
from .errors import AudioError, InputError
from .progress import GENERATION
from .features.audio import audio_channels, warm_audio_features
from .features.text import TEXT_DIM, TextEmbedder
from .pipelined import (HIDDEN, OUTPUTS, STREAMED_LANGUAGES, WAITING, PendingWords, Restart, automatic_speech, finish,
                        finished, overlap_timings, with_speech, with_words)
from .generator.model import GestureGenerator
from .motion.editing import EditError, Keyframe, edit_spec, fit_speech, keyframe, length_mismatch
from .motion.merge import apply_edit, splice
from .motion.postprocess import check_smoothing
from .motion.sequence import FPS, MotionSequence
from .settings import (DEFAULTS, MAX_SECONDS, MIN_SECONDS, Limits, Plan, PostProcess, Settings, check_method_settings,
                       checked_object)
from .streaming import GenerationResult, Made, Watch, Window, check_output, generation_seconds, made_each, plan_of, \
    windowed
from .tokenizer.model import RVQVAE

class GesturePipeline:
    def __init__(self, backends: dict[str, Backend], device: str | torch.device = "cpu",
                 max_seconds: float = MAX_SECONDS):
        self.backends = dict(backends)          # method -> backend (gesturelsm.backends), in registry order
        self.device = torch.device(device)
        self.max_seconds = max_seconds

    @classmethod
    def from_pretrained(cls, path: str | Path | None = None, device: str = "cpu", methods: list[str] | None = None,
                        max_seconds: float = MAX_SECONDS, warm_up: bool = True,
                        checkpoints: list[str | Path] | None = None) -> "GesturePipeline":
        """Every method with a checkpoint in `path`, a folder with tokenizer/<region>.safetensors and
        generator/<method>.safetensors and/or the authors' reference_*.safetensors (default: the shipped assets/),
        or in `checkpoints`, a list of such folders and single checkpoint files. `methods`: load only these.
        A folder without checkpoints is a CheckpointError naming it."""
        if checkpoints is None:
            checkpoints = [Path(path) if path else ASSETS]
        elif path:
            raise InputError("give either a checkpoint folder or a list of checkpoints, not both")
        pipe = cls(load_backends(checkpoints, methods, device), device, max_seconds)
        if warm_up:
            pipe.warm_up()
        return pipe

    @classmethod
    def from_models(cls, tokenizers: dict[str, RVQVAE], generators: dict[str, GestureGenerator],
                    device: str | torch.device = "cpu", max_seconds: float = MAX_SECONDS) -> "GesturePipeline":
        """A pipeline of our methods from models in memory ({method: generator} sharing `tokenizers`)."""
        return cls(flow_backends(tokenizers, generators), device, max_seconds)

    def warm_up(self) -> None:
        """Load the text encoder and compile librosa's onset kernels now, so that one-off start-up costs
        (~3 s) are not counted in the first request's feature time."""
        TextEmbedder.shared().available  # loads the model
        warm_audio_features()

    @property
    def methods(self) -> list[str]:
        return list(self.backends)

    def spec(self, method: str) -> MethodSpec:
        return self._backend(method).spec

    def bounds(self, method: str) -> Bounds:
        """The steps and CFG scales `method` accepts (its spec)."""
        return self.spec(method).bounds

    @property
    def limits(self) -> Limits:
        return Limits(self.max_seconds)

    @property
    def generators(self) -> dict[str, GestureGenerator]:
        """Our loaded generator networks, for tools that reach into them (live streaming, speed and latent analyses)."""
        return {k: b.model for k, b in self.backends.items() if isinstance(b, FlowBackend)}

    @property
    def tokenizers(self) -> dict[str, RVQVAE]:
        """The tokenizers of our first loaded generator (empty when only the authors' methods are loaded)."""
        return next((b.tokenizers for b in self.backends.values() if isinstance(b, FlowBackend)), {})

    def _backend(self, method: str) -> Backend:
        if method not in self.backends:
            raise InputError(f"unknown method {method!r}; available: {', '.join(self.methods)}")
        return self.backends[method]

    # ---- speech ------------------------------------------------------------------------------------------
    def checked_audio(self, audio: np.ndarray, sr: int) -> tuple[np.ndarray, int]:
        """Mono 16 kHz samples cut to whole frames, and their frame count T; bad audio raises InputError."""
        y = to_mono(audio)
        if sr <= 0:
            raise InputError(f"invalid sample rate {sr}")
        y = resample(y, int(sr), SAMPLE_RATE)
        dur = len(y) / SAMPLE_RATE
        if not np.isfinite(y).all():
            raise InputError("the audio contains invalid samples (NaN or infinity)")
        if dur < MIN_SECONDS:
            raise InputError(f"the audio is {dur:.2f} s long; at least {MIN_SECONDS} s of speech is needed")
        if dur > self.max_seconds:
            raise InputError(f"the audio is {dur:.0f} s long; the limit is {self.max_seconds:g} s (a setting: "
                             "max_seconds)")
        if np.abs(y).max() < 1e-4:
            raise InputError("the audio is silent: there is no speech to gesture to")
        T = int(len(y) * FPS // SAMPLE_RATE)
        return y[: int(round(T * SAMPLE_RATE / FPS))], T

    def prefetch_transcript(self, audio: np.ndarray, sr: int = SAMPLE_RATE, language: str = AUTO) -> AutomaticWords:
        """Transcribe now what prepare_speech(audio, sr) would transcribe, so that it finds the words ready
        (asr.source remembers them by content); returns them. Bad audio raises InputError, as prepare_speech would."""
        return automatic_words(self.checked_audio(audio, sr)[0], language=language)

    def remember_transcript(self, audio: np.ndarray, sr: int, words: AutomaticWords, language: str = AUTO) -> None:
        """Words `prefetch_transcript` returned in another process for this audio: prepare_speech(audio, sr) here
        uses them instead of transcribing again."""
        remember_words(self.checked_audio(audio, sr)[0], words, language)

    def prepare_speech(self, audio: np.ndarray, sr: int = SAMPLE_RATE, words: list | None = None,
                       text: str | None = None, progress: Progress | None = None,
                       transcribe: bool = True, language: str = AUTO, stream: bool = False) -> SpeechInput:
        """Validate and resample audio; word timings from aligning a typed `text` (with `language`'s eSpeak voice),
        else from `words` (e.g. a TextGrid), else from automatic transcription (`transcribe`, in `language`: see
        gesturelsm.asr), else audio-only. Features that do not depend on the method are computed here once.
        `stream`: automatic English words are recognised on a thread while `generate` already works on the first
        windows (gesturelsm.pipelined; the same motion as without); the speech's words, mode and transcript are those
        of `settled(speech)` once generated."""
        t0 = time.perf_counter()
        y, T = self.checked_audio(audio, sr)
        typed = bool(text and text.strip())
        pending = None
        if stream and not typed and words is None and transcribe and language in STREAMED_LANGUAGES \
                and not TextEmbedder.shared().error:           # the words are recognised while the features are made
            if progress:
                progress(0.1, "recognising the words (automatic transcription)")
            pending = PendingWords.begin(SpeechInput(y, T, None, None, None, None, ""), language, automatic_words,
                                         progress)
        try:
            once = warm_audio_features()                 # one-off (the first speech of a process): not feature time
            channels = torch.from_numpy(audio_channels(y))
            speech = SpeechInput(y, T, channels, None, torch.zeros(T, TEXT_DIM), torch.zeros(T, dtype=torch.bool),
                                 "audio-only (no transcript given)", {"features": time.perf_counter() - t0 - once},
                                 [], None)
            if progress:
                progress(0.1, "audio features")       # a request's progress may raise: it was stopped
        except BaseException:
            if pending is not None:
                pending.abandon()
            raise
        if pending is not None:
            return pending.attach(speech)
        if typed and not gesture_words(language, text):
            return replace(speech, text_mode=f"audio-only (a Chinese or Japanese transcript: {NOT_FOR_GESTURES})")
        if typed:
            if progress:
                progress(0.1, "timing the transcript's words")
            t1 = time.perf_counter()
            res = align_words(y, text, typed_alignment(language, text))
            speech.timings["alignment"] = time.perf_counter() - t1
            mode = f"transcript, word timings aligned automatically ({res.method}, confidence {res.confidence:.2f})"
            if progress:
                progress(0.2, "transcript aligned")
            return with_words(speech, res.words, mode, warnings=[res.warning] if res.warning else [])
        if words is not None:
            return with_words(speech, words, "transcript with given word timings")
        if not transcribe:
            return speech
        if progress:
            progress(0.1, "recognising the words (automatic transcription)")
        t1 = time.perf_counter()
        auto = automatic_words(y, language=language)
        if progress:
            progress(0.2, "speech transcribed")
        return automatic_speech(speech, auto, time.perf_counter() - t1)

    @staticmethod
    def settled(speech: SpeechInput) -> SpeechInput:
        """The finished speech of pipelined speech (its words known: waits for them); other speech as it is."""
        return speech.stream.settle() if speech.stream is not None else speech

    # ---- generation --------------------------------------------------------------------------------------
    def check_settings(self, method: str, steps: int, cfg: float) -> None:
        """The method is loaded, its steps and CFG scale within its spec's bounds (the settings' validator)."""
        check_method_settings(self.spec(method), steps, cfg)

    def check_plan(self, plan: Plan) -> None:
        """All of a plan's settings, before any work is done."""
        for m in plan.generators:
            self.check_settings(m, plan.steps_for(m), plan.settings.cfg)
        check_smoothing(plan.settings.post.smoothing)

    def run_order(self, plan: Plan) -> list[str]:
        """The order a plan's methods are made in: the ground-truth take first (a lookup), then the generators by
        step count, fewest first, so the first motion is ready as early as possible (ties keep the plan's order)."""
        gens = sorted(plan.generators, key=plan.steps_for)
        return [GROUND_TRUTH] * (GROUND_TRUTH in plan.methods) + gens

    def generate_each(self, speech: SpeechInput, plan: Plan, progress: Progress | None = None, body=None,
                      keep_going: bool = False) -> Iterator[Made]:
        """The plan's methods one by one, each as soon as it is made and finished: `stream(speech, plan=plan,
        windows=False)`, on the caller's thread (a `window_previews` listener of the caller hears its windows)."""
        return self.stream(speech, plan=plan, progress=progress, body=body, keep_going=keep_going, windows=False)

    def stream(self, speech: np.ndarray | SpeechInput, sr: int = SAMPLE_RATE, words: list | None = None,
               text: str | None = None, *, settings: Settings | None = None, plan: Plan | None = None,
               output: str = "finished", body=None, progress: Progress | None = None, keep_going: bool = False,
               windows: bool = True) -> Iterator[Window | Made]:
        """Motion as it is made, for every method of `settings` (or of `plan`: the settings and where ground truth is
        looked up; neither: the defaults), in `run_order` (fewest steps first). For each method: a `Window` after each
        window the sampler makes final, its raw motion so far (from frame 0; decoded with context each side, the
        whole decoding's frames to float rounding: gesturelsm.streaming), then one `Window(whole=True)`, its whole raw
        motion (bit for bit `generate(..., output="raw")`), then its `Made`: bit for bit what `generate` returns for
        that method with these settings (`output`, `body` as there). The speech (samples at `sr` with `words` /
        `text`, as `generate` takes them, or prepared) is prepared once for all methods. The methods run on a thread
        of the stream's own (`progress` is called from it); closing the iterator early stops them at the next window.
        `keep_going`: a method that fails yields a `Made` with its error and the next is made (else the error is
        raised here). `windows=False`: only the `Made`s, made on the caller's thread as it reads (`generate_each`)."""
        plan = plan_of(settings, plan)
        check_output(output)

        def made(watch: Watch | None = None, prog: Progress | None = progress) -> Iterator[Made]:
            prepared = speech if isinstance(speech, SpeechInput) else self.prepare_speech(
                speech, sr, words, text, prog, plan.settings.transcribe, plan.settings.language, stream=True)
            yield from made_each(self, prepared, plan, output, body, prog, keep_going, watch)
        return windowed(made, progress) if windows else made()

    @torch.no_grad()
    def generate(self, audio: np.ndarray | SpeechInput, sr: int = SAMPLE_RATE, words: list | None = None,
                 text: str | None = None, steps: int | None = None, cfg: float = DEFAULTS.cfg,
                 seed: int = DEFAULTS.seed, method: str = DEFAULTS.methods[0], progress: Progress | None = None,
                 transcribe: bool = DEFAULTS.transcribe, *, settings: Settings | None = None,
                 output: str = "finished", body=None) -> GenerationResult:
        """One method's motion for the speech (audio, or speech prepared once by `prepare_speech`). `settings`, when
        given, decides every setting (its first method, that method's steps, CFG, seed, post-processing,
        transcription, language); else the keywords do (`steps` None: the method's spec default) with the default
        post-processing. `output` (OUTPUTS): "finished", the motion fitted to the speech, post-processed on `body`
        (stand in place, smoothing, feet on the ground; default the mannequin) and keeping its words, exactly what
        `gesturelsm generate` writes and the page shows; "raw", the motion as the method sampled and decoded it."""
        check_output(output)
        post, language = DEFAULTS.post, DEFAULTS.language
        if settings is not None:
            method, cfg, seed, transcribe = settings.methods[0], settings.cfg, settings.seed, settings.transcribe
            steps, post, language = settings.steps_for(method), settings.post, settings.language
        steps = self.spec(method).default_steps if steps is None else steps
        self.check_settings(method, steps, cfg)
        speech = audio if isinstance(audio, SpeechInput) else self.prepare_speech(audio, sr, words, text, progress,
                                                                                       transcribe, language,
                                                                                       stream=True)
        prog = GENERATION.span(progress, "method", prefix=f"{method}: ")
        out, speech, timings = self._streamed(speech, method,
                                              lambda sp: self.backends[method].generate(sp, steps, cfg, seed, prog))
        if progress:
            progress(1.0, f"{method}: done")
        motion, note = (out.motion, None) if output == "raw" else finished(out.motion, speech, post, body)
        return GenerationResult(motion, method, int(steps), float(cfg), int(seed),
                                {**speech.timings, **out.timings, **timings},
                                speech.text_mode, list(speech.warnings) + out.warnings + ([note] if note else []))

    def _streamed(self, speech: SpeechInput, method: str, make) -> tuple:
        """(make(speech), the finished speech, overlap timings): with pipelined speech `make` runs while the words are
        recognised, and again on the finished speech where they were not the streamed words (pipelined.Restart)."""
        pending, t0, early = speech.stream, time.perf_counter(), {}
        if pending is not None and (pending.done or not isinstance(self.backends[method], FlowBackend)):
            early = {WAITING: 0.0, HIDDEN: 0.0}                    # words known before; the authors' models read
            speech, pending = self.settled(speech), None           # them at once
        try:
            out = make(speech)
        except Restart:                                            # not the streamed words: as the one-shot path
            out = None
        if pending is None:
            return out, speech, early
        speech = pending.settle()
        out, again = (out, False) if out is not None and pending.valid else (make(speech), True)
        return out, speech, overlap_timings(pending, t0, out.timings, again)

    # ---- editing -----------------------------------------------------------------------------------------
    @torch.no_grad()
    def edit(self, motion: MotionSequence, speech: np.ndarray | SpeechInput, regenerate: Mapping[str, Sequence],
             keyframes: Sequence = (), method: str = DEFAULTS.methods[0], steps: int | None = None,
             cfg: float = DEFAULTS.cfg, seed: int = DEFAULTS.seed, sr: int = SAMPLE_RATE, words: list | None = None,
             text: str | None = None, transcribe: bool = DEFAULTS.transcribe, post: PostProcess = DEFAULTS.post,
             body=None, progress: Progress | None = None, language: str = DEFAULTS.language, *,
             settings: Settings | None = None) -> GenerationResult:
        """`motion` with the regions of `regenerate` ({region: [(start_s, end_s), ...]}) generated anew from the
        speech it goes with, conditioned on everything kept, and `keyframes` ([(time_s, pose source)], sources as
        motion.editing.keyframe takes them) pinned. The result is as long as `motion` and is the input's values bit
        for bit wherever nothing is regenerated; inside a range an edited region crosses over from the input's
        motion at each end, without a jump (motion/merge.py). The regenerated motion is post-processed by `post` as
        a generation is (stand in place, smoothing, feet on the ground on `body`; grounding only when the lower body
        is regenerated, the only region it changes) before it is merged: the input is a finished motion and is not
        processed again. Only methods whose spec says `inpainting` can edit. `settings`, when given, decides every
        setting (as for `generate`), checked by the settings' validator; else the keywords do."""
        if settings is not None:
            method, steps, cfg, seed, transcribe, post, language = \
                checked_object(settings, self.methods, self.limits).one_call()
        spec = self.spec(method)
        if not spec.inpainting:
            able = [m for m in self.methods if self.spec(m).inpainting]
            raise EditError(f"{method} cannot edit a motion: its sampler cannot hold known latents; methods that "
                            f"can: {', '.join(able) or 'none is loaded'}")
        if motion.fps != FPS:
            raise EditError(f"the motion is at {motion.fps} fps; an edit needs a {FPS} fps motion (as generate "
                            "writes and BEAT2 has)")
        steps = spec.default_steps if steps is None else steps
        self.check_settings(method, steps, cfg)
        check_smoothing(post.smoothing)
        keys = [k if isinstance(k, Keyframe) else keyframe(*k, current=motion) for k in keyframes]
        ask = edit_spec(regenerate, motion.num_frames, keys, spec.regions, method)
        speech, warnings = self._edit_speech(motion, speech, sr, words, text, transcribe, progress, language)
        prog = GENERATION.span(progress, "method", prefix=f"{method}: ")
        out, speech, streamed = self._streamed(speech, method,
                                               lambda sp: self.backends[method].edit(sp, motion, ask, steps, cfg, seed,
                                                                                     prog))
        warnings += speech.warnings
        t0 = time.perf_counter()
        gen, note = replace(post, grounding=post.grounding and "lower" in ask.regions).apply(
            splice(motion, out.motion, out.start, ask.regions), body)
        merged = with_speech(apply_edit(motion, gen, ask), speech)
        if progress:
            progress(1.0, f"{method}: edited {ask.describe()}")
        return GenerationResult(merged, method, int(steps), float(cfg), int(seed),
                                {**speech.timings, **out.timings, **streamed, "merging": time.perf_counter() - t0},
                                speech.text_mode, warnings + out.warnings + ([note] if note else []))

    def _edit_speech(self, motion: MotionSequence, speech: np.ndarray | SpeechInput, sr: int, words: list | None,
                     text: str | None, transcribe: bool, progress: Progress | None,
                     language: str = DEFAULTS.language) -> tuple[SpeechInput, list[str]]:
        """The speech of an edit, exactly as long as the motion: given prepared, it must be; given as samples, it
        is cut or padded with silence when it differs by a little (motion.editing.fit_speech)."""
        if isinstance(speech, SpeechInput):
            if speech.num_frames != motion.num_frames:
                raise EditError(length_mismatch(motion.num_frames, speech.duration))
            return speech, []
        if sr <= 0:
            raise InputError(f"invalid sample rate {sr}")
        y, warnings = fit_speech(resample(to_mono(speech), int(sr), SAMPLE_RATE), motion.num_frames)
        return self.prepare_speech(y, SAMPLE_RATE, words, text, progress, transcribe, language, stream=True), warnings


__all__ = ["OUTPUTS", "finished", "with_speech", "GesturePipeline", "GenerationResult", "Made", "Window", "Plan",
           "SpeechInput", "InputError", "AudioError", "ASSETS", "GROUND_TRUTH", "finish", "generation_seconds"]
