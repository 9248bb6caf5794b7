"""The one pure-Python entry point: speech (+ transcript) -> SMPL-X motion. The app, the CLI, the
benchmarks and the tests all call this.

    pipe = GesturePipeline.from_pretrained()            # shipped checkpoints in assets/
    res = pipe.generate(audio, sr, text="hello there", steps=8, cfg=2.0, seed=0, method="gesturelsm")
    res.motion.save("out.npz")                          # BEAT2-compatible npz, 30 fps
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import torch

from .align import align_words
from .asr.source import automatic_words
from .audio import SAMPLE_RATE, resample, to_mono
from .constants import ASSETS, Progress
from .errors import AudioError, InputError
from .data.lookup import find_beat2_take, take_motion
from .features.audio import audio_channels
from .features.text import TEXT_DIM, TextEmbedder
from .flows import FACTS
from .generator.model import GestureGenerator
from .generator.sampling import decode_latents, generate_latents
from .motion.postprocess import DEFAULT_SMOOTHING, check_smoothing, fit_length, postprocess
from .motion.regions import GENERATED_REGIONS, join_regions
from .motion.sequence import FPS, MotionSequence
from .reference.runner import REFERENCE_FACTS, attach_reference, generate_for_pipeline
from .tokenizer.model import RVQVAE

# every method a pipeline can run: ours (flows registry) and the authors' released weights (reference/)
ALL_FACTS = {**FACTS, **REFERENCE_FACTS}

MIN_SECONDS = 0.5
MAX_CFG = 10.0
GROUND_TRUTH = "ground_truth"          # a "method" of a plan: the BEAT2 take's own motion


@dataclass
class SpeechInput:
    """Speech prepared once and reusable across methods, steps and seeds."""
    audio: np.ndarray                   # (N,) 16 kHz mono float32
    num_frames: int
    channels: torch.Tensor              # (2, N) envelope + onsets
    words: list | None                  # list[Word] used, or None (audio-only)
    word_features: torch.Tensor         # (T, 384)
    has_word: torch.Tensor              # (T,) bool
    text_mode: str                      # how the transcript was used, said to the user
    timings: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    transcript: str | None = None       # the automatic transcript's text when one was recognised and used

    @property
    def duration(self) -> float:
        return self.num_frames / FPS


@dataclass
class GenerationResult:
    motion: MotionSequence
    method: str
    steps: int
    cfg: float
    seed: int
    timings: dict[str, float]           # seconds: features, alignment, sampling, decoding
    text_mode: str
    warnings: list[str]

    @property
    def generation_seconds(self) -> float:
        """Inference time without transcript alignment (the paper's AITS convention)."""
        return sum(v for k, v in self.timings.items() if k not in ("alignment", "transcription"))

    @property
    def real_time_factor(self) -> float:
        return self.motion.duration / max(self.generation_seconds, 1e-9)


@dataclass
class Plan:
    """What to make from one prepared speech: which methods, with which settings, post-processed how."""
    methods: Sequence[str]                     # generator keys and/or GROUND_TRUTH, in the order shown
    steps: Mapping[str, int] = field(default_factory=dict)   # per method; missing: the method's default_steps
    cfg: float = 2.0
    seed: int = 0
    stand_in_place: bool = False
    smoothing: str = DEFAULT_SMOOTHING         # motion.postprocess.SMOOTHING_WINDOWS
    beat2: str | None = None                   # BEAT2-layout folder where GROUND_TRUTH is looked up
    filename: str | None = None                # the speech file's name (a take is recognised by it first)

    def steps_for(self, method: str) -> int:
        return int(self.steps.get(method, ALL_FACTS[method].default_steps))

    @property
    def generators(self) -> list[str]:
        return [m for m in dict.fromkeys(self.methods) if m != GROUND_TRUTH]


@dataclass
class Generated:
    """The motions of one plan, each exactly as long as the speech and post-processed."""
    motions: dict[str, MotionSequence]         # method (or GROUND_TRUTH) -> motion, in the plan's order
    results: dict[str, GenerationResult]       # generator methods: timings and settings
    ground_truth: str | None                   # the BEAT2 take recognised, if asked for and found
    warnings: list[str]


class GesturePipeline:
    def __init__(self, tokenizers: dict, generators: dict, device: str | torch.device = "cpu",
                 max_seconds: float = 600.0):
        self.tokenizers = tokenizers            # region -> RVQVAE
        self.generators = generators            # method -> GestureGenerator
        self.device = torch.device(device)
        self.max_seconds = max_seconds
        for g in generators.values():
            if tuple(g.config.regions) != tuple(tokenizers):
                raise ValueError(f"generator regions {g.config.regions} do not match tokenizers {tuple(tokenizers)}")

    @classmethod
    def from_pretrained(cls, path: str | Path | None = None, device: str = "cpu", methods: list[str] | None = None,
                        max_seconds: float = 600.0, warm_up: bool = True) -> "GesturePipeline":
        """`path`: a folder with tokenizer/<region>.safetensors and generator/<method>.safetensors
        (default: the shipped assets/)."""
        root = Path(path) if path else ASSETS
        ref_root = root if (root / "reference_rvq.safetensors").exists() else None  # authors' weights (import-reference)
        if ref_root is not None and not (root / "tokenizer").exists():
            root = ASSETS                                                           # ours beside theirs
        tok_dir, gen_dir = root / "tokenizer", root / "generator"
        missing = [r for r in GENERATED_REGIONS if not (tok_dir / f"{r}.safetensors").exists()]
        if missing:
            raise FileNotFoundError(f"{tok_dir}: missing tokenizer checkpoints for {', '.join(missing)}")
        tokenizers = {r: RVQVAE.load(tok_dir / f"{r}.safetensors").to(device) for r in GENERATED_REGIONS}
        gens = {}
        for p in sorted(gen_dir.glob("*.safetensors")):
            if methods is None or p.stem in methods:
                gens[p.stem] = GestureGenerator.load(p).to(device)
        if not gens and ref_root is None:
            raise FileNotFoundError(f"{gen_dir}: no generator checkpoints found")
        pipe = cls(tokenizers, gens, device, max_seconds)
        attach_reference(pipe, ref_root)
        if warm_up:
            pipe.warm_up()
        return pipe

    def warm_up(self) -> None:
        """Load the text encoder and compile librosa's onset kernels now, so that one-off start-up costs
        (~3 s) are not counted in the first request's feature time."""
        TextEmbedder.shared().available  # noqa: B018 (loads the model)
        audio_channels(np.random.default_rng(0).normal(scale=0.1, size=SAMPLE_RATE).astype(np.float32))

    @property
    def methods(self) -> list[str]:
        return list(self.generators) + list(getattr(self, "reference_methods", {}))

    # ---- speech ------------------------------------------------------------------------------------------
    def _checked_audio(self, audio: np.ndarray, sr: int) -> tuple[np.ndarray, int]:
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
            raise InputError(f"the audio is {dur / 60:.1f} minutes long; the limit is {self.max_seconds / 60:.0f} "
                             "minutes (a setting: max_seconds)")
        if np.abs(y).max() < 1e-4:
            raise InputError("the audio is silent: there is no speech to gesture to")
        T = int(len(y) * FPS // SAMPLE_RATE)
        return y[: int(round(T * SAMPLE_RATE / FPS))], T

    def prefetch_transcript(self, audio: np.ndarray, sr: int = SAMPLE_RATE) -> None:
        """Transcribe now what prepare_speech(audio, sr) would transcribe, so that it finds the words ready
        (asr.source remembers them by content). Bad audio raises InputError, as prepare_speech would."""
        automatic_words(self._checked_audio(audio, sr)[0])

    def prepare_speech(self, audio: np.ndarray, sr: int = SAMPLE_RATE, words: list | None = None,
                       text: str | None = None, progress: Progress | None = None,
                       transcribe: bool = True) -> SpeechInput:
        """Validate and resample audio; word timings from aligning a typed `text`, else from `words` (e.g. a
        TextGrid), else from automatic transcription (`transcribe`), else audio-only. Features that do not
        depend on the method are computed here once."""
        timings: dict[str, float] = {}
        warnings: list[str] = []
        t0 = time.perf_counter()
        y, T = self._checked_audio(audio, sr)
        channels = torch.from_numpy(audio_channels(y))
        timings["features"] = time.perf_counter() - t0
        if progress:
            progress(0.1, "audio features")
        mode, transcript = "audio-only (no transcript given)", None
        if text and text.strip():
            t1 = time.perf_counter()
            res = align_words(y, text)
            timings["alignment"] = time.perf_counter() - t1
            words = res.words
            mode = f"transcript, word timings aligned automatically ({res.method}, confidence {res.confidence:.2f})"
            if res.warning:
                warnings.append(res.warning)
            if progress:
                progress(0.2, "transcript aligned")
        elif words is not None:
            mode = "transcript with given word timings"
        elif transcribe:
            t1 = time.perf_counter()
            auto = automatic_words(y)
            timings["transcription"] = time.perf_counter() - t1
            words, mode, transcript = auto.words, auto.text_mode, auto.transcript
            transcript = transcript.text if transcript is not None and auto.words else None
            warnings += auto.warnings
            if progress:
                progress(0.2, "speech transcribed")
        wf, hw = torch.zeros(T, TEXT_DIM), torch.zeros(T, dtype=torch.bool)
        if words:
            t2 = time.perf_counter()
            emb = TextEmbedder.shared()
            if emb.available:
                ft = emb.frame_features(words, T)
                wf, hw = torch.from_numpy(ft.features), torch.from_numpy(ft.has_word)
            else:
                warnings.append(f"{emb.error}; generating from audio only")
                words, mode = None, "audio-only (text encoder unavailable)"
            timings["features"] += time.perf_counter() - t2
        return SpeechInput(y, T, channels, words or None, wf, hw, mode, timings, warnings,
                           transcript if words else None)

    # ---- generation --------------------------------------------------------------------------------------
    def check_settings(self, method: str, steps: int, cfg: float) -> None:
        """The one place settings are checked: the method is loaded, steps within the method's registered
        bounds (flows.FACTS), 0 <= CFG <= MAX_CFG."""
        if method not in self.methods:
            raise InputError(f"unknown method {method!r}; available: {', '.join(self.methods)}")
        hi = ALL_FACTS[method].max_steps
        if not isinstance(steps, (int, np.integer)) or not 1 <= steps <= hi:
            raise InputError(f"The number of steps must be a whole number from 1 to {hi} for {method} (got {steps})")
        if not np.isfinite(cfg) or not 0.0 <= cfg <= MAX_CFG:
            raise InputError(f"CFG scale must be between 0 and {MAX_CFG:g} (got {cfg})")

    def check_plan(self, plan: Plan) -> None:
        """All of a plan's settings, before any work is done."""
        for m in plan.generators:
            self.check_settings(m, plan.steps_for(m), plan.cfg)
        check_smoothing(plan.smoothing)

    def generate_all(self, speech: SpeechInput, plan: Plan, progress: Progress | None = None) -> Generated:
        """One request: every generator of the plan on the same speech, the ground-truth take if asked for (and
        recognised), each fitted to the speech's length, then post-processed (stand in place, smoothing)."""
        self.check_plan(plan)
        T = speech.num_frames
        gens = plan.generators
        motions: dict[str, MotionSequence] = {}
        results: dict[str, GenerationResult] = {}
        warnings = list(speech.warnings)
        for i, m in enumerate(gens):
            lo, hi = i / max(1, len(gens)), (i + 1) / max(1, len(gens))
            prog = (lambda f, msg, lo=lo, hi=hi: progress(lo + (hi - lo) * f, msg)) if progress else None
            res = self.generate(speech, steps=plan.steps_for(m), cfg=float(plan.cfg), seed=int(plan.seed), method=m,
                                progress=prog)
            results[m], motions[m] = res, res.motion
            warnings += [w for w in res.warnings if w not in warnings]   # e.g. the authors' models: face neutral
        gt_name = None
        if GROUND_TRUTH in plan.methods:
            gt_name = find_beat2_take(plan.beat2, speech.audio, plan.filename)
            if gt_name is None:
                warnings.append("Ground truth was asked for, but the speech is not a take of the BEAT2 folder; "
                                "it is left out.")
            else:
                motions[GROUND_TRUTH] = fit_length(take_motion(plan.beat2, gt_name), T)
        motions = {k: postprocess(v.slice(0, T), plan.stand_in_place, plan.smoothing) for k, v in motions.items()}
        return Generated(motions, results, gt_name, warnings)

    @torch.no_grad()
    def generate(self, audio: np.ndarray | SpeechInput, sr: int = SAMPLE_RATE, words: list | None = None,
                 text: str | None = None, steps: int = 8, cfg: float = 2.0, seed: int = 0,
                 method: str = "gesturelsm", progress: Progress | None = None,
                 transcribe: bool = True) -> GenerationResult:
        self.check_settings(method, steps, cfg)
        speech = audio if isinstance(audio, SpeechInput) else self.prepare_speech(audio, sr, words, text, progress,
                                                                                       transcribe)
        if method in getattr(self, "reference_methods", {}):   # the authors' released weights (reference/)

            motion, t, warn = generate_for_pipeline(self, speech, method, steps, cfg, seed)
            return GenerationResult(motion, method, int(steps), float(cfg), int(seed), {**speech.timings, **t},
                                    speech.text_mode, list(speech.warnings) + warn)
        gen = self.generators[method]
        timings = dict(speech.timings)
        t0 = time.perf_counter()
        prog = (lambda f, m: progress(0.2 + 0.7 * f, f"{method}: {m}")) if progress else None
        lat = generate_latents(gen, speech.channels, speech.word_features, speech.has_word, speech.words is not None,
                               speech.num_frames, steps, cfg, seed, prog)
        timings["sampling"] = time.perf_counter() - t0
        t1 = time.perf_counter()
        parts = decode_latents(self.tokenizers, lat.to(self.device), speech.num_frames)
        feats = join_regions({k: v.cpu() for k, v in parts.items()})
        motion = MotionSequence.from_features(feats)
        timings["decoding"] = time.perf_counter() - t1
        if progress:
            progress(1.0, f"{method}: done")
        return GenerationResult(motion, method, int(steps), float(cfg), int(seed), timings, speech.text_mode,
                                list(speech.warnings))


__all__ = ["GesturePipeline", "GenerationResult", "Generated", "Plan", "SpeechInput", "InputError", "AudioError",
           "ASSETS", "GROUND_TRUTH", "MAX_CFG"]
