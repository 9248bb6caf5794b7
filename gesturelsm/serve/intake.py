"""A request's way in, before any motion: the upload's presence and size, every field through the settings' validator
with the server's limits, the upload read as 16 kHz speech once per file, and the speech prepared once for every
method (features, the words typed / from the TextGrid / recognised), remembered per upload (`serve/prepared.py`).

    intake = Intake(pipeline, settings)
    req, plan = intake.check(req)                                   # InputError: every problem, one line each
    plan, speech, notes = intake.speech(req, None, progress)        # the upload read and prepared (or remembered)
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Hashable

import numpy as np

from ..audio import SAMPLE_RATE, AudioTooLongError, load_audio
from ..backends import GROUND_TRUTH, SPECS
from ..constants import Progress
from ..errors import AudioError, InputError
from ..pipeline import Plan, SpeechInput
from ..settings import Limits
from .ahead import motion_key
from .checks import check_request, textgrid_words
from .config import ServiceSettings
from .limits import transcript_problems
from .prepared import PreparedUploads, file_key
from .request import VIDEO_SIZES, Request

SPEECH_AHEAD = ("The speech was prepared when it was uploaded, before Generate was clicked (audio features, word "
                "timings, the automatic transcript): the table shows the time each took then.")


class Intake:
    """The checks and the speech preparation of one server (module docstring)."""

    def __init__(self, pipeline, settings: ServiceSettings, uploads: PreparedUploads | None = None):
        self.pipeline, self.settings = pipeline, settings
        self.uploads = uploads if uploads is not None else PreparedUploads()

    @property
    def limits(self) -> Limits:
        """What this server accepts beyond each method's own bounds: speech length, and the sliders' ends as step caps
        for every request (Generate, Sweep, the API)."""
        st = self.settings
        return Limits(st.max_seconds, {"steps": st.max_steps, "ddim_steps": st.max_ddim_steps})

    @property
    def methods(self) -> list[str]:
        """Choices for the page: the loaded generators in registry order, then ground truth when a BEAT2 folder is
        set."""
        order = {m: i for i, m in enumerate(SPECS)}
        gens = sorted(self.pipeline.methods, key=lambda m: order.get(m, len(order)))
        return gens + ([GROUND_TRUTH] if self.settings.beat2 else [])

    def motion_key(self, req: Request, plan: Plan) -> Hashable:
        """What the motion of a checked request depends on (`serve/ahead.py`)."""
        return motion_key(file_key(req.audio_path), self.speech_key(req, plan), plan)

    @staticmethod
    def speech_key(req: Request, plan: Plan) -> tuple:
        """The transcript settings an upload's speech is prepared for."""
        return ((req.text or "").strip(), file_key(req.textgrid_path), plan.settings.transcribe, plan.settings.language)

    def _upload(self, audio_path) -> list[str]:
        """The upload is there and within the size limit: [] or the problem."""
        if not audio_path or not isinstance(audio_path, (str, os.PathLike)):
            return ["Please record or upload speech first (any common audio format)."]
        p = Path(audio_path)
        if not p.is_file():
            return ["The uploaded audio file is missing on the server; please upload it again."]
        mb = p.stat().st_size / 2 ** 20
        if mb > self.settings.max_upload_mb:
            return [f"The audio file is {mb:.0f} MB; the limit is {self.settings.max_upload_mb:.0f} MB."]
        return []

    def check(self, req: Request, need_file: bool = True, extra: list[str] | None = None) -> tuple[Request, Plan]:
        """The upload's presence and size, then every field (the settings' validator, `gesturelsm.settings`, with this
        server's limits): all problems at once (with `extra` ones found by the caller), one line each, before any
        work; returns the request with normalised values and its plan."""
        upload = self._upload(req.audio_path) if need_file else []
        req, settings, problems = check_request(req, self.methods, self.limits, VIDEO_SIZES)
        problems = upload + problems + (extra or [])
        if problems:
            raise InputError("\n".join(problems))
        name = Path(req.audio_path).name if req.audio_path else None
        return req, Plan(settings, self.settings.beat2, name)

    def _words(self, req: Request, seconds: float) -> tuple[list | None, list[str]]:
        """Word timings of the uploaded TextGrid (None without one) and notes for the page, bounded by the
        speech's length (`gesturelsm.serve.checks.textgrid_words`)."""
        if not req.textgrid_path:
            return None, []
        words, problems, notes = textgrid_words(req.textgrid_path, seconds)
        if problems:
            raise InputError("\n".join(problems))
        return words, notes

    def load(self, req: Request, extra: list[str] | None = None) -> tuple[Request, Plan, np.ndarray]:
        """Checks (`check`), then the upload read as 16 kHz speech within the server's length limit, once per file
        (`serve/prepared.py`: an upload's prefetch has usually read it)."""
        req, plan = self.check(req, extra=extra)
        path = req.audio_path
        return req, plan, self.uploads.decoded(path, lambda: self.read(path))

    def read(self, path: str) -> np.ndarray:
        """The file as 16 kHz speech within the server's length limit; AudioError with the visitor's line."""
        try:
            return load_audio(path, max_seconds=self.settings.max_seconds)
        except AudioTooLongError as exc:
            raise AudioError(f"The audio is too long: {exc}") from None
        except AudioError as exc:
            raise AudioError(f"The audio could not be read: {exc}") from None

    def speech(self, req: Request, audio: np.ndarray | None, prog: Progress, extra: list[str] | None = None,
               stream: bool = False) -> tuple[Plan, SpeechInput, list[str]]:
        """Checks (`check`), then the speech prepared once for every method (the transcript typed, from the TextGrid,
        recognised or none, as the request says), and notes for the page; for an upload, what its prefetch prepared
        (`serve/prepared.py`), else prepared here and remembered. Automatic words are recognised on a thread: with
        `stream` the speech may come back before them (generation joins them), else once they are known."""
        path = None
        if audio is None:
            req, plan, audio = self.load(req, extra)
            path = req.audio_path
        else:
            req, plan = self.check(req, need_file=False, extra=extra)
        seconds = len(audio) / SAMPLE_RATE
        problems = transcript_problems(req.text, seconds)
        if problems:
            raise InputError("\n".join(problems))

        fresh = []

        def prepare() -> tuple[SpeechInput, list[str]]:
            fresh.append(True)
            words, notes = self._words(req, seconds)
            prog(0.0, "reading speech")
            live = [True]                                # the words' thread says nothing once this returns
            speech = self.pipeline.prepare_speech(audio, SAMPLE_RATE, words=words, text=req.text or None,
                                                  progress=lambda f, m: live[0] and prog(f, m),
                                                  transcribe=plan.settings.transcribe,
                                                  language=plan.settings.language, stream=True)
            live[0] = False
            return speech, notes
        speech, notes = prepare() if path is None else self.uploads.prepared(path, self.speech_key(req, plan), prepare)
        if path is not None and not fresh:  # prepared at the upload: its stages' times are the ones spent then, said so
            notes = [*notes, SPEECH_AHEAD]
        return plan, speech if stream else self.pipeline.settled(speech), notes


__all__ = ["Intake", "SPEECH_AHEAD"]
