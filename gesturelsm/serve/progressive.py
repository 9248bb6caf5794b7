"""One request's result as it grows, for the page that shows each method the moment its motion exists.

`stream_request(shop, req)` (`shop`: the `Workshop` of the server's pipeline, checks, runs made ahead and request
folders) yields `Result`s: the first once the speech is prepared (no motion yet, every method
`pending`; automatic words may still be being recognised: the first method's generation starts on the windows whose
words are final, gesturelsm/pipelined.py, and the results say the finished speech's text mode once they are known),
then one per method made, fastest first (`GesturePipeline.run_order`), each holding every motion made so
far in the page's order, their timing rows and notes (the methods made ahead of the click, `serve/ahead.py`, come in
the first result); the last is what `GestureService.run` returns before the video
and the downloads. With `previews` (the page) the methods are made on a thread of their own and, until the first
method's motion is made, a result comes each time its decoded windows have doubled (the first at once), holding that
raw motion so far in `previews` (serve/preview.py; made ahead or not, the same): the page's first body moves before
its method is finished; the motions in `motions` are always the finished ones. A method that fails does not stop the
others: the result names it in `failed` (method -> the visitor's line) and in a note; only when no method is made is
its error raised. A failure that is not one of the errors a visitor can fix (a `GestureError`) is logged with its
traceback and shown as a failure on the server.
"""
from __future__ import annotations

import logging
import threading
import time
from dataclasses import replace
from typing import Iterator

import numpy as np
import torch

from ..constants import Progress
from ..backends import GROUND_TRUTH_LABEL, label
from ..errors import GestureError, InputError
from ..generator.sampling import window_previews
from ..motion.sequence import MotionSequence
from ..pipeline import GROUND_TRUTH, Made, Plan, SpeechInput
from ..progress import REQUEST
from .ahead import Cancelled, Run
from .intake import SPEECH_AHEAD
from .request import RenderJob, Request, Result, timing_rows
from .workshop import Workshop

log = logging.getLogger("gesturelsm.app")


MADE_AHEAD = ("Made ahead: generation started after the upload with these settings, before Generate was clicked "
              "(the same settings and seed make the same motion; the table's times are the generation's own, spent "
              "before the click: its rows say \"made ahead\").")
WORDS_AHEAD = ("The words were recognised before Generate was clicked (at the upload, or for an earlier request of the "
               "same speech): the table shows the time their transcription took then.")


class MethodFailed(GestureError):
    """Every method of a request failed on the server; the message names them."""


def slot_label(method: str, plan: Plan) -> str:
    """The label a method's body carries on the page and in the video."""
    if method == GROUND_TRUTH:
        return f"{GROUND_TRUTH_LABEL} (BEAT2)"
    return f"{label(method)} {plan.steps_for(method)} steps CFG {plan.settings.cfg:g}"


def failure(method: str, exc: Exception) -> str:
    """The visitor's line for a method that failed: its message when it is one meant for them, else a server fault
    (logged with its traceback)."""
    if isinstance(exc, GestureError):
        return str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    log.error("generating %s failed", method, exc_info=exc)
    return "it failed on the server"


class Growing:
    """The made methods of one request and the `Result` they add up to so far."""

    def __init__(self, plan: Plan, speech: SpeechInput, notes: list[str], folder, size: int, started: float):
        self.plan, self.speech, self.notes, self.folder, self.size = plan, speech, notes, folder, size
        self.started = started
        self.slots = plan.generators + [GROUND_TRUTH] * (GROUND_TRUTH in plan.methods)
        self.made: dict[str, Made] = {}
        self.failed: dict[str, str] = {}
        self.ready_s = 0.0
        self.ahead: list[str] = []                          # methods made before the click
        self.ahead_s: float | None = None                   # the wall time their making took (before the click)

    def add(self, x: Made) -> None:
        self.made[x.method] = x
        if x.error is not None:
            self.failed[x.method] = failure(x.method, x.error)
        elif x.motion is None:                              # the ground truth of a speech that is not a BEAT2 take
            self.slots.remove(x.method)
        self.ready_s = time.perf_counter() - self.started

    def moving(self) -> bool:
        """Whether a method's motion is made (the page's first body moves on it: no more previews)."""
        return any(x.motion is not None for x in self.made.values())

    def result(self, preview: tuple[str, MotionSequence] | None = None) -> Result:
        """The result so far; `preview`: (method, raw motion so far) of the method being made."""
        made = {m: self.made[m] for m in self.slots if m in self.made and self.made[m].motion is not None}
        motions = {m: x.motion for m, x in made.items()}
        gens = {m: x.result for m, x in made.items() if x.result is not None}
        labels = [slot_label(m, self.plan) for m in motions]
        gen_s = [gens[m].generation_seconds if m in gens else None for m in motions]
        sp = self.speech
        job = RenderJob(self.folder, tuple(motions.values()), tuple(labels), tuple(gen_s), sp.audio, sp.duration,
                        self.size, self.started, self.plan.settings.post.grounding)
        has_gt = GROUND_TRUTH in motions
        timings = {m: dict(r.timings) for m, r in gens.items()}
        ahead = tuple(m for m in self.ahead if m in motions)
        speech_ahead = SPEECH_AHEAD in self.notes
        words_ahead = "transcription" in sp.earlier and not speech_ahead
        rows = timing_rows(timings, has_gt, sp.duration, None, ahead, speech_ahead, words_ahead=words_ahead)
        warnings = list(sp.warnings)
        for x in self.made.values():
            warnings += [w for w in x.warnings if w not in warnings]
        warnings += [f"{label(m)}: {self.failed[m]}" for m in self.slots if m in self.failed]
        warnings += self.notes + ([WORDS_AHEAD] if words_ahead else [])
        take = self.made[GROUND_TRUTH].take if has_gt else None
        pending = tuple(m for m in self.slots if m not in self.made)
        return Result(None, rows, (), None, sp.text_mode, tuple(warnings), take, self.ready_s, self.ready_s, timings,
                      motions, sp.transcript, job, speech=sp, plan=self.plan, pending=pending,
                      failed={m: self.failed[m] for m in self.slots if m in self.failed},
                      slots=tuple((m, slot_label(m, self.plan)) for m in self.slots), made_ahead=ahead,
                      ahead_seconds=self.ahead_s if ahead else None, speech_ahead=speech_ahead,
                      previews=dict([preview]) if preview is not None and preview[0] in pending else {})


def stream_request(shop: Workshop, req: Request, progress: Progress | None = None,
                   audio: np.ndarray | None = None, previews: bool = False) -> Iterator[Result]:
    """The request's result after the speech is prepared and after each method, with `previews` also as the first
    method's windows come (module docstring), made with `shop`'s checks, prepared speech, motion made ahead,
    pipeline and request folders."""
    with shop.ahead.generating():                        # no motion is made ahead while a request generates
        yield from _stream(shop, req, progress, audio, previews)


def _stream(shop: Workshop, req: Request, progress: Progress | None, audio: np.ndarray | None,
            previews: bool = False) -> Iterator[Result]:
    started = time.perf_counter()
    prog = rising(progress) if progress else (lambda f, m: None)
    torch.set_num_threads(shop.threads)                     # in the thread that serves it (Gradio's worker)
    shop.folders.cleanup()
    # its words may still be recognised: generation joins them as they come
    plan, speech, notes = shop.intake.speech(req, audio, REQUEST.span(prog, "speech"), stream=True)
    grow = Growing(plan, speech, notes, shop.folders.new(), int(req.size), started)
    if audio is None:
        run = shop.ahead.take(shop.intake.motion_key(req, plan))
    else:                                                # samples, not an upload: nothing was made ahead for them
        shop.ahead.cancel()
        run = None
    ready = len(run.made) if run is not None else 0      # made before the click: shown at once, in one result
    if GROUND_TRUTH not in plan.methods and not ready:   # else the take's lookup comes first and settles its slot
        yield grow.result()
    events = _events(shop, plan, speech, run, prog) if previews else \
        (("made", x) for x in _made(shop, plan, speech, run, prog))
    i, shown = -1, 0
    for kind, x in events:
        if kind == "preview":
            if not grow.moving() and i + 1 >= ready and not 0 < shown <= x.num_frames < 2 * shown:
                making = next((m for m in shop.pipeline.run_order(plan) if m != GROUND_TRUTH and
                               m not in grow.made), None)
                if making is not None:                   # each shown preview at least doubles the one before
                    shown = x.num_frames
                    yield grow.result((making, x))
            continue
        i += 1
        if run is not None and any(x is y for y in run.made):
            if MADE_AHEAD not in grow.notes:
                grow.notes = grow.notes + [MADE_AHEAD]
            grow.ahead.append(x.method)
            grow.ahead_s = run.seconds(x)
        grow.speech = known(grow.speech)
        grow.add(x)
        if i + 1 >= ready:
            yield grow.result()
    if not grow.result().motions:
        errors = list({id(x.error): x.error for x in grow.made.values() if x.error is not None}.values())
        if len(errors) == 1 and isinstance(errors[0], GestureError):
            raise errors[0]
        if errors:
            raise MethodFailed("; ".join(f"{label(m)}: {grow.failed[m]}" for m in grow.slots
                                         if m in grow.failed))
        raise InputError("Nothing to show: choose a generator method.")


def rising(progress: Progress) -> Progress:
    """`progress` that never goes back: a method whose words, recognised alongside its generation, turn out not to be
    the ones to use is made again (gesturelsm/pipelined.py `Restart`); the bar stays where it was meanwhile."""
    top = [0.0]

    def say(f: float, message: str) -> None:
        top[0] = max(top[0], f)
        progress(top[0], message)
    return say


def known(speech: SpeechInput) -> SpeechInput:
    """The finished speech once its words are known (what the results say: text mode, transcript, warnings; edits
    reuse it); speech whose words are still being recognised, or could not be, as it is."""
    pending = speech.stream
    if pending is None or not pending.done or pending.error is not None:
        return speech
    return pending.settle()


def _made(shop: Workshop, plan: Plan, speech: SpeechInput, run, prog: Progress) -> Iterator[Made]:
    """The plan's methods as they are made: by the run made ahead for them (`serve/ahead.py`) when there is one, and
    here what it did not make (a run that stopped on an error of the server's)."""
    todo = list(plan.methods)
    if run is not None:
        for x in run.items():
            if x.method in todo:
                todo.remove(x.method)
            REQUEST.span(prog, "methods")(1 - len(todo) / len(plan.methods), f"{label(x.method)} made")
            yield x
        if not todo:
            return
        plan = replace(plan, settings=replace(plan.settings, methods=tuple(todo)))
    yield from shop.pipeline.generate_each(speech, plan, progress=REQUEST.span(prog, "methods"),
                                           body=shop.body, keep_going=True)


def _events(shop: Workshop, plan: Plan, speech: SpeechInput, run: Run | None, prog: Progress) -> Iterator[tuple]:
    """`_made` with previews: ("made", Made) for each method and ("preview", MotionSequence) for each window of the
    first method as it comes, read from the run made ahead when there is one, else from a run on a thread of its own
    (`own_run`: its progress is said here, in the request's thread); that run is stopped if the reader stops."""
    todo = list(plan.methods)
    if run is not None:
        for kind, x in read(run):
            if kind == "made":
                if x.method in todo:
                    todo.remove(x.method)
                REQUEST.span(prog, "methods")(1 - len(todo) / len(plan.methods), f"{label(x.method)} made")
            if kind != "progress":
                yield kind, x
        if not todo:
            return
        plan = replace(plan, settings=replace(plan.settings, methods=tuple(todo)))
    own = own_run(shop, plan, speech)
    try:
        for kind, x in read(own):
            if kind == "progress":
                REQUEST.span(prog, "methods")(*x)
            else:
                yield kind, x
        if own.error is not None:
            raise own.error
    finally:
        own.cancelled.set()                              # a closed page: it stops at its next window
        own.thread.join()


def own_run(shop: Workshop, plan: Plan, speech: SpeechInput) -> Run:
    """`plan`'s methods made on a thread of its own at the server's math threads, the first one's windows shown as
    they come (`Run.preview`); what stops it (other than cancelling) is kept in `Run.error`."""
    run = Run(None, what=", ".join(plan.methods))
    run.taken = True
    threads = shop.threads

    def work() -> None:
        failed = False
        try:
            torch.set_num_threads(threads)
            with window_previews(run.preview):
                for x in shop.pipeline.generate_each(speech, plan, progress=run.say, body=shop.body,
                                                     keep_going=True):
                    run.add(x)
        except Cancelled:
            failed = True
        except BaseException as exc:  # handed to the request's thread
            run.error, failed = exc, True
        finally:
            run.finish(failed)
    run.thread = threading.Thread(target=work, name="gesturelsm-generate", daemon=True)
    run.thread.start()
    return run


def read(run: Run) -> Iterator[tuple]:
    """What `run` makes as it makes it: ("made", Made) for each method, ("preview", MotionSequence) for each new
    preview of the method being made, ("progress", (fraction, message)) for each `Run.say`; ends with the run."""
    i, seen, said = 0, 0, None
    cond = run.preview.cond
    while True:
        with cond:
            while i >= len(run.made) and not run.done and run.preview.version == seen and run.said is said:
                cond.wait()
            if i < len(run.made):
                event, i = ("made", run.made[i]), i + 1
            elif run.said is not said:
                said = run.said
                event = ("progress", said)
            elif run.preview.version != seen:
                seen = run.preview.version
                event = None if run.preview.stopped else ("preview", run.preview.motion)
            else:
                return
        if event is not None:
            yield event
