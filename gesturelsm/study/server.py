"""The study server (`gesturelsm study serve`): a small Starlette app over a study folder and a database.

Routes (everything a rater can reach; the key, file names and method names are never sent):
    GET  /r/<token>                         the trial page (the same static page for everyone)
    POST /api/<token>/open                  the page loaded: this tab takes the study over; returns the state
    POST /api/<token>/answer                {session, trial, choice | ratings, played}: one answer, the next state
    GET  /api/<token>/video/<trial>/<side>  a video of a trial already on screen (left | right), Range requests
Refusals are HTTP 4xx with {"error": message}, and a database that cannot take an answer just now is 503 with
{"error": message} (store.py); the page shows the message. A state is
{n, k, trial: {index, kind, question?, scales?} | null, code: completion code | null}.
Database work runs off the event loop (store.Store), so a slow or locked database never holds up pages and videos.
Videos carry their size and type only: no modification time (it would order the conditions by render time) and
no validator such as an ETag (the same one in two trials would link them); the address is per rater and trial.
"""
from __future__ import annotations

import json
import re
import sys
import traceback
from dataclasses import dataclass
from pathlib import Path

from starlette.applications import Starlette
from starlette.requests import Request
from starlette.responses import FileResponse, HTMLResponse, JSONResponse, Response
from starlette.routing import Route

from ..errors import GestureError
from . import db
from .design import QUESTIONS, SCALE_QUESTIONS, SCALES, Rater, read_design, read_raters
from .page import PAGE
from .store import Store

MAX_BODY = 4096
MAX_DEPTH = 8               # JSON nesting a request may have (answers need 2)
MAX_DIGITS = 12             # digits a number in a request may have
CHOICES = ("left", "right", "none")
TRIAL = re.compile(r"[0-9]{1,9}")


@dataclass
class Study:
    """A study folder's raters (reloaded when `study invite` adds some) and its answers database."""
    folder: Path
    store: Store
    _raters: dict[str, Rater]
    _mtime: float = 0.0
    question: str | None = None                 # the design's own question (the page's default otherwise)

    @classmethod
    def open(cls, folder: str | Path, url: str | None = None, log=print) -> "Study":
        folder = Path(folder)
        design = read_design(folder)                    # a clear error when the folder is not a study
        study = cls(folder, Store.open(folder, url, log), {}, question=QUESTIONS.get(design.mode))
        study._reload()
        return study

    @property
    def engine(self):
        return self.store.engine

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
            if self.question and t.kind == "pair":
                trial["question"] = self.question
            if t.kind == "rating":
                trial["scales"] = [dict(name=s, question=SCALE_QUESTIONS[s]) for s in SCALES]
        return dict(n=n, k=st.answered, trial=trial, code=st.code)


def _api(handler):
    """A route that answers JSON whatever happens: refusals as {"error": message} with their status, and a bug as
    a 500 with a message the page can show (the traceback goes to the server's console)."""
    async def route(request: Request) -> Response:
        try:
            return await handler(request)
        except GestureError as exc:                    # a refusal: its status (400 when it names none)
            return JSONResponse({"error": str(exc)}, status_code=getattr(exc, "status", 400))
        except Exception:                              # a bug: the page still gets a message
            traceback.print_exc(file=sys.stderr)
            return JSONResponse({"error": "the study server failed on this request; please try again, or tell "
                                          "the study's organiser"}, status_code=500)
    return route


class _TooLong(ValueError):
    pass


def _int(text: str) -> int:
    if len(text.lstrip("-")) > MAX_DIGITS:
        raise _TooLong(text)
    return int(text)


def _depth(raw: bytes) -> int:
    """The deepest nesting of arrays and objects in a JSON text (brackets inside strings do not count)."""
    depth = deepest = 0
    in_string = escaped = False
    for b in raw:
        if in_string:
            if escaped:
                escaped = False
            elif b == 0x5C:                           # backslash
                escaped = True
            elif b == 0x22:
                in_string = False
        elif b == 0x22:
            in_string = True
        elif b in (0x5B, 0x7B):
            depth += 1
            deepest = max(deepest, depth)
        elif b in (0x5D, 0x7D):
            depth -= 1
    return deepest


async def _json_body(request: Request) -> dict:
    if int(request.headers.get("content-length") or 0) > MAX_BODY:
        raise db.RequestRefused(413, "the request is too large")
    raw = b""
    async for chunk in request.stream():
        raw += chunk
        if len(raw) > MAX_BODY:
            raise db.RequestRefused(413, "the request is too large")
    if _depth(raw) > MAX_DEPTH:
        raise db.RequestRefused(400, f"the request is nested too deeply (more than {MAX_DEPTH} levels)")
    try:
        body = json.loads(raw, parse_int=_int)
    except _TooLong:
        raise db.RequestRefused(400, f"a number in the request is too long (more than {MAX_DIGITS} digits)") from None
    except (ValueError, UnicodeDecodeError, RecursionError):
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


class VideoResponse(FileResponse):
    """A video file with its size and type only: no Last-Modified and no ETag (set_stat_headers), and an If-Range
    (which could only name a validator never sent) is ignored, so a Range request always gets its range."""

    def set_stat_headers(self, stat_result) -> None:       # os.stat_result
        self.headers.setdefault("content-length", str(stat_result.st_size))

    async def __call__(self, scope, receive, send) -> None:  # ASGI
        scope = dict(scope, headers=[(k, v) for k, v in scope.get("headers", []) if k.lower() != b"if-range"])
        await super().__call__(scope, receive, send)


def _open_and_show(engine, rater: Rater) -> db.RaterState:
    st = db.open_session(engine, rater.id, 0)
    if st.code is None and st.shown_trial < len(rater.trials):
        db.show(engine, rater.id, st.session, st.shown_trial)
    return st


def _record(engine, store: Store, rater: Rater, session: str, trial: int, **answer) -> db.RaterState:
    """One answer written, then read back from the database file: only then is it acknowledged."""
    nxt = trial + 1 if trial + 1 < len(rater.trials) else None
    st = db.record(engine, rater.id, session, trial, next_trial=nxt, n_trials=len(rater.trials), **answer)
    store.verify(rater.id, trial, st.shown_at)
    return st


def build_app(study: Study) -> Starlette:
    store = study.store

    async def page(request: Request) -> Response:
        try:
            study.rater(request.path_params["token"])
        except GestureError as exc:
            return HTMLResponse(f"<!doctype html><title>Study</title><p>{exc}</p>",
                                status_code=getattr(exc, "status", 400))
        return HTMLResponse(PAGE, headers={"Cache-Control": "no-store", "Referrer-Policy": "no-referrer"})

    @_api
    async def open_(request: Request) -> Response:
        rater = study.rater(request.path_params["token"])
        st = await store.write(_open_and_show, rater, action="open")
        return JSONResponse(dict(session=st.session, **study.state(rater, st)))

    @_api
    async def answer(request: Request) -> Response:
        rater = study.rater(request.path_params["token"])
        body = await _json_body(request)
        session, trial = _field(body, "session", str), _field(body, "trial", int)
        if not 0 <= trial < len(rater.trials):
            raise db.RequestRefused(400, f"there is no trial {trial} in this study")
        played = body.get("played", False)
        if not isinstance(played, bool):
            raise db.RequestRefused(400, "'played' must be true or false")
        choice, ratings = _answer_fields(body, rater.trials[trial].kind)
        st = await store.write(_record, store, rater, session, trial, choice=choice, ratings=ratings, played=played)
        return JSONResponse(study.state(rater, st))

    @_api
    async def video(request: Request) -> Response:
        rater = study.rater(request.path_params["token"])
        text, side = request.path_params["trial"], request.path_params["side"]
        if side not in ("left", "right") or not TRIAL.fullmatch(text) or int(text) >= len(rater.trials):
            raise db.RequestRefused(404, "no such video for this rater")
        trial = int(text)
        if trial > await store.read(db.shown_trial, rater.id):   # videos need no session: <video> sends no body
            raise db.RequestRefused(404, "no such video for this rater")
        t = rater.trials[trial]
        name = t.left if side == "left" else t.right
        if not name:
            raise db.RequestRefused(404, "this trial has one video")
        return VideoResponse(study.folder / "videos" / name, media_type="video/mp4",
                             headers={"Cache-Control": "private, max-age=3600"})

    async def not_found(request: Request, exc: Exception) -> Response:
        return JSONResponse({"error": "not found"}, status_code=404)

    routes = [Route("/r/{token}", page), Route("/api/{token}/open", open_, methods=["POST"]),
              Route("/api/{token}/answer", answer, methods=["POST"]),
              Route("/api/{token}/video/{trial}/{side}", video)]
    return Starlette(routes=routes, exception_handlers={404: not_found})


def serve(folder: str | Path, host: str = "127.0.0.1", port: int = 8600, url: str | None = None,
          log=print) -> None:
    """Serve the study until interrupted (answers are committed as they come: stopping loses nothing)."""
    import uvicorn

    study = Study.open(folder, url, log)
    log(f"study {folder}: {len(study._raters)} raters; links: http://{host}:{port}/r/<token> "
        f"(tokens in {Path(folder) / 'key' / 'links.csv'})")
    try:
        uvicorn.run(build_app(study), host=host, port=port, log_level="warning")
    finally:
        study.store.close()


__all__ = ["Study", "VideoResponse", "build_app", "serve"]
