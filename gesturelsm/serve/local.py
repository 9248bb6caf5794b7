"""Generation in this process (`serve/port.py` `Generation`): a request's motion made here from its upload
(`serve/progressive.py`, with the motion made ahead of the click: `serve/ahead.py`), edits (`serve/editing.py`),
sweeps (`serve/sweep.py`), the video in a render process of its own (render/background.py) and the downloads
written into the request's folder (`request_files.py` names them)."""
from __future__ import annotations

import logging
import os
import secrets
import time
from dataclasses import replace
from pathlib import Path
from typing import Callable, Hashable, Iterator, Sequence

import numpy as np
import torch

from ..body.model import resolve_model_path
from ..constants import Progress
from ..errors import CancelToken, GestureError, RenderError
from ..evaluation.sweep import SweepLimits
from ..export import export_arkit, export_bvh, export_glb, export_keypoints, export_npz
from ..motion.sequence import MotionSequence
from ..progress import REQUEST
from ..render.background import render_apart
from ..settings import DEFAULTS
from .config import ServiceSettings
from .editing import edit_result
from ..request_files import ARKIT, BVH, GLB, KEYPOINTS, NPZ, VIDEO, method_file
from .progressive import stream_request
from .renders import RenderQueue, video_progress, waiting_line
from .request import Request, Result, result_rows, with_render_time
from .sweep import SweepOutcome, SweepRequest, run_sweep_request
from .workshop import Workshop

log = logging.getLogger("gesturelsm.app")


def in_turn(renders: RenderQueue, video: Callable[..., Result], result: Result, progress: Progress | None = None,
            cancelled: Callable[[], bool] | None = None, character=None, owner: Hashable | None = None) -> Result:
    """`video(result, progress, cancelled, character)` once the render queue gives `owner` its turn, with the render
    time in the result's rows (`GestureService.render` says the rest); a result with a video, or without motion,
    comes back as it is."""
    if result.video is not None or not result.motions:
        return result
    prog = progress or (lambda f, m: None)
    with renders.enter(owner) as ticket:
        ticket.wait(lambda position: prog(REQUEST.at("video"), waiting_line(position)), cancelled)
        t_r = time.perf_counter()
        out = video(result, video_progress(REQUEST.span(prog, "video")), CancelToken(ticket.cancelled, cancelled),
                    character)
        render_s = time.perf_counter() - t_r
    return with_render_time(out, render_s, time.perf_counter() - result.job.started)


class LocalGeneration:
    """`Generation` in this process, made with `shop`'s pipeline, checks, runs made ahead and request folders."""

    where = "this process"
    sweep_note = ""

    def __init__(self, shop: Workshop, settings: ServiceSettings, renders: RenderQueue):
        self.shop, self.settings, self.renders = shop, settings, renders

    # ---- motion --------------------------------------------------------------------------------------------
    def run(self, req: Request, progress: Progress | None = None, audio: np.ndarray | None = None) -> Result:
        prog = progress or (lambda f, m: None)
        for result in stream_request(self.shop, req, prog, audio):
            pass
        if req.render:
            result = in_turn(self.renders, self.render, result, prog)
        if req.exports:
            prog(REQUEST.at("exports"), "exports")
            result = self.export(result)
        prog(1.0, "done")
        return result

    def stream(self, req: Request, progress: Progress | None = None, audio: np.ndarray | None = None,
               previews: bool = True) -> Iterator[Result]:
        return stream_request(self.shop, req, progress, audio, previews)

    def edit(self, result: Result, method: str, start, end, regions: Sequence[str] | str, seed,
             progress: Progress | None = None) -> Result:
        ahead = self.shop.ahead
        ahead.cancel()
        with ahead.generating():
            out = edit_result(self.shop.pipeline, result, method, start, end, regions, seed, progress, self.shop.body)
        return replace(out, rows=result_rows(out))

    def sweep(self, req: SweepRequest, limits: SweepLimits = SweepLimits(), progress: Progress | None = None,
              cancelled: Callable[[], bool] | None = None) -> SweepOutcome:
        ahead = self.shop.ahead
        ahead.cancel()
        with ahead.generating():
            return run_sweep_request(self.shop, req, limits, progress, cancelled)

    # ---- before the click ----------------------------------------------------------------------------------
    def prefetch(self, audio_path: str | None, text: str = "", textgrid_path: str | None = None,
                 transcribe: bool = True, ahead: Request | None = None) -> bool:
        """The upload's speech prepared, then `ahead`'s motion made in the background (`GestureService.prefetch`)."""
        if not audio_path:
            return False
        try:
            self.shop.intake.speech(Request(audio_path, text=text or "", textgrid_path=textgrid_path,
                                            transcribe=transcribe,
                                            language=ahead.language if ahead is not None else DEFAULTS.language),
                                    None, lambda f, m: None, stream=True)   # the motion made ahead joins the words
        except GestureError as exc:                      # the request refuses it with this message
            log.info("upload not prepared %s: %s", Path(audio_path).name, " | ".join(str(exc).splitlines()))
            return False
        except Exception:                                # a bug: keep its traceback in the log, not on the page
            log.exception("preparing the upload %s failed", Path(audio_path).name)
            return False
        if ahead is not None:
            try:
                self.make_ahead(ahead)
            except GestureError as exc:                  # settings the click would refuse: nothing made ahead
                log.info("no motion made ahead: %s", " | ".join(str(exc).splitlines()))
            except Exception:
                log.exception("making motion ahead failed")
        return True

    def make_ahead(self, req: Request):
        """Start making `req`'s motion in the background (`GestureService.make_ahead`)."""
        if not self.settings.ahead:
            return None
        shop = self.shop
        req, plan = shop.intake.check(req)

        def make(run):
            torch.set_num_threads(shop.threads)
            _, speech, _ = shop.intake.speech(req, None, lambda f, m: None, stream=True)   # prepared by the prefetch
            return shop.pipeline.generate_each(speech, plan, progress=run.check, body=shop.body, keep_going=True)
        return shop.ahead.start(shop.intake.motion_key(req, plan), make, ", ".join(plan.methods))

    # ---- the video and the files ---------------------------------------------------------------------------
    def render(self, result: Result, progress: Progress, cancelled: Callable[[], bool], character=None) -> Result:
        """The result with its video rendered here (a process of its own, niced: render/background.py)."""
        job = result.job
        video = job.folder / VIDEO
        body = self.shop.body
        # the render process loads the body itself: hand it the file (None: it resolves the default as we would)
        body_path = (body.path if hasattr(body, "path") else None if body is None else resolve_model_path(body))
        try:
            render_apart(list(job.motions), job.audio, video, labels=list(job.labels), size=(job.size, job.size),
                         body_path=body_path, gen_seconds=list(job.gen_seconds), progress=progress,
                         nice=self.settings.render_nice, cancelled=cancelled,
                         rig=character.path if character is not None and character.document is not None else None,
                         grounding=job.grounding)
        except RenderError as exc:
            raise RenderError(f"Rendering failed on the server: {exc}") from None
        return replace(result, video=video)

    def export(self, result: Result) -> Result:
        if not result.motions or result.downloads:
            return result
        files, glb = self._exports(list(result.motions.values()), list(result.motions), result.job.folder)
        return replace(result, downloads=tuple(files), glb=glb)

    def export_each(self, result: Result) -> list[Path]:
        """npz + BVH of each motion of the result (in the page's order), written once per request and method."""
        return [p for seq, name in zip(result.motions.values(), result.motions)
                for p in self._method_files(seq, name, result.job.folder)]

    def _method_files(self, seq: MotionSequence, name: str, out: Path) -> list[Path]:
        """NAME.npz and NAME.bvh in `out`, each written whole under another name first (the page's downloads event
        and the exports after the video may make the same file at once; a file that exists is complete)."""
        files = []
        for path, write in ((method_file(out, name, NPZ), lambda p: export_npz(seq, p)),
                            (method_file(out, name, BVH), lambda p: export_bvh(seq, p, body=self.shop.body))):
            if not path.exists():
                tmp = path.with_name(f".{secrets.token_hex(8)}{path.suffix}")
                write(tmp)
                os.replace(tmp, path)
            files.append(path)
        return files

    def _exports(self, motions: list[MotionSequence], names: list[str], out: Path) -> tuple[list[Path], Path | None]:
        """npz + BVH per method (`export_each`); GLB, keypoints and the ARKit face (Live Link Face CSV) for the first
        one (the interactive view shows that GLB)."""
        files: list[Path] = []
        glb = None
        body = self.shop.body
        for i, (seq, name) in enumerate(zip(motions, names)):
            files += self._method_files(seq, name, out)
            if i == 0:
                glb = export_glb(seq, method_file(out, name, GLB), body=body)
                files.append(glb)
                files.append(export_keypoints(seq, method_file(out, name, KEYPOINTS), body=body))
                files.append(export_arkit(seq, method_file(out, name, ARKIT), body=body))
        return [Path(f) for f in files], glb

    def close(self) -> None:
        """Nothing to stop: the models live as long as the process."""


__all__ = ["LocalGeneration", "in_turn"]
