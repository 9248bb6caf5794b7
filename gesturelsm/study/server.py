"""The study server (`gesturelsm study serve`): a small Starlette app over a study folder and a database.

Routes (everything a rater can reach; the key, file names and method names are never sent):
    GET  /r/<token>                         the trial page (the same static page for everyone)
    POST /api/<token>/open                  the page loaded: this tab takes the study over; returns the state
    POST /api/<token>/answer                {session, trial, choice | ratings, played}: one answer, the next state
    GET  /api/<token>/video/<trial>/<side>  a video of a trial already on screen (left | right), Range requests
Refusals are HTTP 4xx with {"error": message}; the page shows the message. A state is
{n, k, trial: {index, kind, scales?} | null, code: completion code | null}.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import FileResponse, HTMLResponse, JSONResponse, Response
from starlette.routing import Route

from ..errors import GestureError
from . import db
from .design import SCALE_QUESTIONS, SCALES, Rater, read_design, read_raters
from .page import PAGE

MAX_BODY = 4096
CHOICES = ("left", "right", "none")


@dataclass
class Study:
    """A study folder's raters (reloaded when `study invite` adds some) and the database engine."""
    folder: Path
    engine: object
    _raters: dict[str, Rater]
    _mtime: float = 0.0

    @classmethod
    def open(cls, folder: str | Path, url: str | None = None) -> "Study":
        folder = Path(folder)
        read_design(folder)                             # a clear error when the folder is not a study
        study = cls(folder, db.open_db(url or db.default_url(folder)), {})
        study._reload()
        return study

    def _reload(self) -> None:
        path = self.folder / "key" / "raters.json"
        mtime = path.stat().st_mtime if path.exists() else 0.0
        if mtime != self._mtime:
            self._raters, self._mtime = read_raters(self.folder), mtime

    def rater(self, token: str) -> Rater:
        if token not in self._raters:
            self._reload()
        if token not in self._raters:
            raise db.RequestRefused(404, "this study link is not valid; check that you copied all of it")
        return self._raters[token]

    def state(self, rater: Rater, st: db.RaterState) -> dict:
        n = len(rater.trials)
        trial = None
        if st.code is None and st.shown_trial < n:
            t = rater.trials[st.shown_trial]
            trial = dict(index=t.index, kind=t.kind)
            if t.kind == "rating":
                trial["scales"] = [dict(name=s, question=SCALE_QUESTIONS[s]) for s in SCALES]
        return dict(n=n, k=st.answered, trial=trial, code=st.code)


def _refusal(exc: GestureError) -> JSONResponse:
    """The one line a rater's page shows, with the HTTP status of the refusal (400 when it names none)."""
    return JSONResponse({"error": str(exc)}, status_code=getattr(exc, "status", 400))


async def _json_body(request: Request) -> dict:
    if int(request.headers.get("content-length") or 0) > MAX_BODY:
        raise db.RequestRefused(413, "the request is too large")
    raw = b""
    async for chunk in request.stream():
        raw += chunk
        if len(raw) > MAX_BODY:
            raise db.RequestRefused(413, "the request is too large")
    try:
        body = json.loads(raw)
    except (ValueError, UnicodeDecodeError):
        raise db.RequestRefused(400, "the request is not valid JSON") from None
    if not isinstance(body, dict):
        raise db.RequestRefused(400, "the request must be a JSON object")
    return body


def _field(body: dict, name: str, kind: type):
    value = body.get(name)
    if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
        raise db.RequestRefused(400, f"the request needs '{name}' ({kind.__name__})")
    return value


def _answer_fields(body: dict, kind: str) -> tuple[str | None, dict | None]:
    if kind == "pair":
        choice = _field(body, "choice", str)
        if choice not in CHOICES:
            raise db.RequestRefused(400, f"'choice' must be one of {', '.join(CHOICES)}")
        return choice, None
    ratings = _field(body, "ratings", dict)
    if set(ratings) != set(SCALES) or not all(isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= 5
                                              for v in ratings.values()):
        raise db.RequestRefused(400, f"'ratings' must give every scale ({', '.join(SCALES)}) a whole number from 1 "
                                     "to 5")
    return None, {s: ratings[s] for s in SCALES}


def build_app(study: Study) -> Starlette:
    engine = study.engine

    async def page(request: Request) -> Response:
        try:
            study.rater(request.path_params["token"])
        except GestureError as exc:
            return HTMLResponse(f"<!doctype html><title>Study</title><p>{exc}</p>",
                                status_code=getattr(exc, "status", 400))
        return HTMLResponse(PAGE, headers={"Cache-Control": "no-store", "Referrer-Policy": "no-referrer"})

    async def open_(request: Request) -> Response:
        try:
            rater = study.rater(request.path_params["token"])
            st = db.open_session(engine, rater.id, 0)
            if st.code is None and st.shown_trial < len(rater.trials):
                db.show(engine, rater.id, st.session, st.shown_trial)
            return JSONResponse(dict(session=st.session, **study.state(rater, st)))
        except GestureError as exc:
            return _refusal(exc)

    async def answer(request: Request) -> Response:
        try:
            rater = study.rater(request.path_params["token"])
            body = await _json_body(request)
            session, trial = _field(body, "session", str), _field(body, "trial", int)
            if not 0 <= trial < len(rater.trials):
                raise db.RequestRefused(400, f"there is no trial {trial} in this study")
            played = body.get("played", False)
            if not isinstance(played, bool):
                raise db.RequestRefused(400, "'played' must be true or false")
            choice, ratings = _answer_fields(body, rater.trials[trial].kind)
            nxt = trial + 1 if trial + 1 < len(rater.trials) else None
            st = db.record(engine, rater.id, session, trial, choice=choice, ratings=ratings, played=played,
                           next_trial=nxt, n_trials=len(rater.trials))
            return JSONResponse(study.state(rater, st))
        except GestureError as exc:
            return _refusal(exc)

    async def video(request: Request) -> Response:
        try:
            rater = study.rater(request.path_params["token"])
            trial, side = request.path_params["trial"], request.path_params["side"]
            shown = db.shown_trial(engine, rater.id)       # videos need no session: <video> sends no body
            if side not in ("left", "right") or not 0 <= trial < len(rater.trials) or trial > shown:
                raise db.RequestRefused(404, "no such video for this rater")
            t = rater.trials[trial]
            name = t.left if side == "left" else t.right
            if not name:
                raise db.RequestRefused(404, "this trial has one video")
            return FileResponse(study.folder / "videos" / name, media_type="video/mp4",
                                headers={"Cache-Control": "private, max-age=3600"})
        except GestureError as exc:
            return _refusal(exc)

    async def not_found(request: Request, exc: Exception) -> Response:
        return JSONResponse({"error": "not found"}, status_code=404)

    routes = [Route("/r/{token}", page), Route("/api/{token}/open", open_, methods=["POST"]),
              Route("/api/{token}/answer", answer, methods=["POST"]),
              Route("/api/{token}/video/{trial:int}/{side}", video)]
    return Starlette(routes=routes, exception_handlers={404: not_found})


def serve(folder: str | Path, host: str = "127.0.0.1", port: int = 8600, url: str | None = None,
          log=print) -> None:
    """Serve the study until interrupted (answers are committed as they come: stopping loses nothing)."""
    import uvicorn

    study = Study.open(folder, url)
    log(f"study {folder}: {len(study._raters)} raters; links: http://{host}:{port}/r/<token> "
        f"(tokens in {Path(folder) / 'key' / 'links.csv'})")
    uvicorn.run(build_app(study), host=host, port=port, log_level="warning")


__all__ = ["Study", "build_app", "serve"]
