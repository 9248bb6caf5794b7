"""Motion as it is made: what a generation gives back (`GenerationResult`), a plan's methods made one by one
(`made_each`, each a `Made`), and those methods streamed with the raw motion of every window as the sampler makes it
final (`windowed`, `Window` events): the one loop behind `GesturePipeline.stream` and `generate_each`.

A windowed stream runs the methods on a thread of its own, inside `generator.sampling.window_previews`: after each
window the sampler makes final, the new latents are decoded (`generator.sampling.WindowDecoder`: only those, with 16
latents of context before them and, `CONTEXT_AFTER`, 16 final latents after them) and handed over as the method's raw
motion so far, from frame 0. Decoded with context on both sides, as the whole motion's decoding works in chunks, the
frames are the whole decoding's to float rounding (a convolution over another length rounds differently: about 1e-5
rad on the shipped tokenizers); once the method is sampled the stream gives its whole raw motion (`Window.whole`: bit
for bit `output="raw"`), then the method made (`Made`: bit for bit what `GesturePipeline.generate` returns for that
method). At most `WAITING_EVENTS` events wait for the reader: beyond, the generation waits; a reader that stops
reading (closes the stream) stops the generation at its next window.
"""
from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Iterator, Mapping

import numpy as np
import torch

from .backends import GROUND_TRUTH, SpeechInput, label
from .constants import Progress
from .data.lookup import find_beat2_take, take_motion
from .errors import Cancelled, InputError
from .generator.sampling import window_previews
from .motion.postprocess import fit_length
from .motion.regions import TRANS_OFFSET, join_regions
from .motion.sequence import MotionSequence
from .motion.translation import velocity_to_trans
from .progress import span
from .pipelined import HIDDEN, OUTPUTS, WAITING, finished
from .settings import DEFAULTS, Plan, Settings

GROUND_TRUTH_MISSING = ("Ground truth was asked for, but the speech is not a take of the BEAT2 folder; it is left "
                        "out.")
NOT_GENERATION = ("alignment", "transcription", "rendering",     # stages outside generation time (the paper's AITS)
                  WAITING, HIDDEN)
WAITING_EVENTS = 2          # events a windowed stream holds for its reader before the generation waits
CONTEXT_AFTER = 16          # final latents after the frames a window shows (generator.sampling.WindowDecoder `after`)


def generation_seconds(timings: Mapping[str, float]) -> float:
    """Generation time from per-stage seconds: features, sampling and decoding, without transcript alignment or
    recognition (the paper's AITS convention) and without rendering."""
    return sum(v for k, v in timings.items() if k not in NOT_GENERATION)


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
        """Inference time without transcript alignment or recognition (the paper's AITS convention)."""
        return generation_seconds(self.timings)

    @property
    def real_time_factor(self) -> float:
        """Seconds of speech per second of generation (the paper's convention)."""
        return self.motion.duration / max(self.generation_seconds, 1e-9)


@dataclass
class Made:
    """One method of a plan, made (`GesturePipeline.stream`, `generate_each`): its motion as long as the speech,
    finished (post-processed) unless the stream was asked for raw motion (None: it failed, or the ground-truth take
    was not recognised), or the error it failed with."""
    method: str
    motion: MotionSequence | None
    result: GenerationResult | None = None     # a generator's timings and settings (its motion: the raw one)
    take: str | None = None                    # the BEAT2 take recognised (GROUND_TRUTH)
    warnings: list[str] = field(default_factory=list)
    error: Exception | None = None


@dataclass(frozen=True)
class Window:
    """The raw motion of `method` so far (from frame 0; as decoded, before post-processing), after one more window
    (the frames up to `CONTEXT_AFTER` latents before its end: module docstring). Within a method the windows grow;
    `whole`: the method's whole raw motion, its last window. A window with fewer frames than the one before starts
    the method again (its automatically recognised words were not the streamed ones: pipelined.Restart)."""
    method: str
    motion: MotionSequence
    whole: bool = False

    @property
    def frames(self) -> int:
        return self.motion.num_frames


def raw_motion(parts: Mapping[str, torch.Tensor], before: MotionSequence | None = None) -> MotionSequence:
    """Decoded regions ({region: (frames, C) features from frame 0}, as `generator.sampling.decode_latents` gives)
    as motion. `before`: the motion of fewer of the same frames (an earlier window of the same decoding): its frames
    are kept and only the ones after it converted (the root's path, a sum of steps, from all of them)."""
    x = join_regions({k: v.cpu() for k, v in parts.items()})
    if before is None or before.num_frames >= x.shape[0]:
        return MotionSequence.from_features(x)
    new = MotionSequence.from_features(x[before.num_frames:])
    return replace(new, poses=np.concatenate([before.poses, new.poses]),
                   trans=velocity_to_trans(x[:, TRANS_OFFSET:TRANS_OFFSET + 3]).numpy(),
                   expressions=np.concatenate([before.expressions, new.expressions]))


def plan_of(settings: Settings | None, plan: Plan | None) -> Plan:
    """The plan of a stream given settings (ground truth not looked up), a plan, or neither (the defaults)."""
    if settings is not None and plan is not None:
        raise InputError("give either settings or a plan (its settings and where ground truth is), not both")
    return plan if plan is not None else Plan(settings if settings is not None else DEFAULTS)


def check_output(output: str) -> None:
    if output not in OUTPUTS:
        raise ValueError(f"output must be one of {', '.join(OUTPUTS)}, not {output!r}")


class Watch:
    """What `made_each` tells a stream besides the methods made: a method begun and its whole raw motion."""

    def begin(self, method: str) -> None:
        """`method` is being made next."""

    def raw(self, method: str, motion: MotionSequence) -> None:
        """`method`'s whole raw motion (sampled and decoded; the fitted take for ground truth)."""


def made_each(pipe: Any, speech: SpeechInput, plan: Plan, output: str = "finished", body=None,
              progress: Progress | None = None, keep_going: bool = False, watch: Watch | None = None
              ) -> Iterator[Made]:
    """The plan's methods one by one in `pipe.run_order` (a GesturePipeline), each as soon as it is made: generated
    raw (`pipe.generate(output="raw")`), then fitted to the speech's length and, for `output="finished"`,
    post-processed (pipelined.finished: stand in place, smoothing, feet on the ground on `body`, default the
    mannequin or $GESTURELSM_SMPLX_MODEL), exactly as `pipe.generate` finishes one method. With `keep_going` a
    method that fails yields its error and the next one is made; otherwise the error is raised."""
    check_output(output)
    pipe.check_plan(plan)
    T, order = speech.num_frames, pipe.run_order(plan)
    for i, m in enumerate(order):
        prog = span(progress, i / len(order), (i + 1) / len(order))     # each method its share in turn
        if watch is not None:
            watch.begin(m)
        try:
            if m == GROUND_TRUTH:
                take = find_beat2_take(plan.beat2, speech.audio, plan.filename)
                motion = None if take is None else fit_length(take_motion(plan.beat2, take), T)
                made = Made(m, motion, take=take, warnings=[] if take else [GROUND_TRUTH_MISSING])
            else:
                res = pipe.generate(speech, steps=plan.steps_for(m), cfg=plan.settings.cfg, seed=plan.settings.seed,
                                    method=m, progress=prog, output="raw")
                speech = pipe.settled(speech)
                made = Made(m, res.motion, res, warnings=res.warnings)  # e.g. the authors' models: face neutral
            if made.motion is not None and watch is not None:
                watch.raw(m, made.motion)
            if made.motion is not None and output == "finished":
                made.motion, note = finished(made.motion, speech, plan.settings.post, body)
                made.warnings = made.warnings + ([f"{label(m)}: {note}"] if note else [])
        except Exception as exc:  # the caller reports it with the methods that were made
            if not keep_going:
                raise
            made = Made(m, None, error=exc)
        yield made


class _Events(Watch):
    """A windowed stream's events from the generating thread to the reader (at most `size` unread: `put` waits
    beyond), and the listener of `window_previews` that makes them."""

    context_after = CONTEXT_AFTER

    def __init__(self, progress: Progress | None, size: int = WAITING_EVENTS):
        self.user_progress, self.size = progress, size
        self.cond = threading.Condition()
        self.items: deque = deque()
        self.closed = self.done = False
        self.error: BaseException | None = None
        self.method = ""
        self.last: MotionSequence | None = None    # the method's motion so far, as the last window gave it

    def put(self, item: Window | Made) -> None:
        with self.cond:
            while len(self.items) >= self.size and not self.closed:
                self.cond.wait()
            if not self.closed:
                self.items.append(item)
                self.cond.notify_all()

    def finish(self, error: BaseException | None = None) -> None:
        with self.cond:
            self.done, self.error = True, error
            self.cond.notify_all()

    def close(self) -> None:
        with self.cond:
            self.closed = True
            self.cond.notify_all()

    def get(self) -> Window | Made | None:
        """The next event; None once the generation is over (its error raised here)."""
        with self.cond:
            while not self.items and not self.done:
                self.cond.wait()
            if self.items:
                item = self.items.popleft()
                self.cond.notify_all()
                return item
        if self.error is not None:
            raise self.error
        return None

    # the generating thread's side: Watch, window_previews' listener, progress
    def begin(self, method: str) -> None:
        self.method, self.last = method, None

    def raw(self, method: str, motion: MotionSequence) -> None:
        self.put(Window(method, motion, whole=True))

    def wanted(self) -> bool:
        return not self.closed

    def show(self, parts: dict[str, torch.Tensor]) -> None:
        last = self.last if self.last is not None and self.last.num_frames < len(next(iter(parts.values()))) else None
        self.last = raw_motion(parts, last)             # fewer frames than the last: the method made again
        self.put(Window(self.method, self.last))

    def progress(self, fraction: float, message: str) -> None:
        if self.closed:
            raise Cancelled("the stream was closed: no more motion is wanted")
        if self.user_progress is not None:
            self.user_progress(fraction, message)


def windowed(made: Callable[[Watch, Progress], Iterator[Made]], progress: Progress | None = None
             ) -> Iterator[Window | Made]:
    """The events of `made(watch, progress)` (a `made_each`) run on a thread of its own: each method's `Window`s as
    its windows are sampled, its whole raw motion, then its `Made` (module docstring). Closing this iterator stops
    the generation at its next window and waits for the thread."""
    events = _Events(progress)

    def work() -> None:
        try:
            with window_previews(events):
                for x in made(events, events.progress):
                    if events.closed:
                        break
                    events.put(x)
        except BaseException as exc:  # handed to the reader
            events.finish(exc)
        else:
            events.finish()

    thread = threading.Thread(target=work, name="gesturelsm-stream", daemon=True)
    thread.start()
    try:
        while (item := events.get()) is not None:
            yield item
    finally:
        events.close()
        thread.join()


__all__ = ["GROUND_TRUTH_MISSING", "GenerationResult", "Made", "Watch", "Window", "check_output", "generation_seconds",
           "made_each", "plan_of", "raw_motion", "windowed"]
