"""Responses in a database through SQLAlchemy: SQLite in the study folder by default, any SQLAlchemy URL
(e.g. postgresql://...) for a hosted study.

Tables
    raters   one row per rater who opened their link: the tab (session) that holds the study now, which trial
             was last shown and when (for time on trial), the completion code once every trial is answered
    answers  one row per (rater, trial), unique: rater, trial, choice (left / right / none, or the ratings as
             JSON), seconds on the trial (from when the server showed it), whether both videos were played to
             the end, when it was written

Every answer is one transaction: the answer row and the rater's next trial are written together or not at all;
a second submission of the same trial breaks the unique constraint and is refused, so nothing counts twice.
"""
from __future__ import annotations

import json
import secrets
import time
from dataclasses import dataclass
from pathlib import Path

from sqlalchemy import (JSON, Boolean, Column, Float, ForeignKey, Integer, MetaData, String, Table,
                        UniqueConstraint, create_engine, event, func, insert, select, update)
from sqlalchemy.engine import Engine
from sqlalchemy.exc import ArgumentError, IntegrityError, NoSuchModuleError, OperationalError

from ..errors import InputError, UserError

metadata = MetaData()
raters = Table(
    "raters", metadata,
    Column("id", Integer, primary_key=True),            # the rater id of key/raters.json
    Column("session", String(64), nullable=False),      # the tab that holds the study now
    Column("shown_trial", Integer, nullable=False),
    Column("shown_at", Float, nullable=False),
    Column("started_at", Float, nullable=False),
    Column("completed_at", Float),
    Column("code", String(32)),
)
answers = Table(
    "answers", metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("rater", Integer, ForeignKey("raters.id"), nullable=False),
    Column("trial", Integer, nullable=False),
    Column("choice", String(16)),                       # pairwise: left / right / none
    Column("ratings", JSON),                            # rating: {scale: 1..5}
    Column("seconds", Float, nullable=False),
    Column("played", Boolean, nullable=False),
    Column("created_at", Float, nullable=False),
    UniqueConstraint("rater", "trial", name="one_answer_per_trial"),
)


class RequestRefused(InputError):
    """A rater's request the study refuses; `status` is the HTTP status, the message is shown on the rater's page."""

    def __init__(self, status: int, message: str):
        super().__init__(message)
        self.status = status


@dataclass
class RaterState:
    id: int
    session: str
    shown_trial: int
    shown_at: float
    answered: int
    code: str | None


def default_url(study: str | Path) -> str:
    return f"sqlite:///{Path(study).resolve() / 'responses.sqlite'}"


def open_db(url: str) -> Engine:
    """An engine with the tables created. SQLite gets WAL (readers do not block the writer), a busy timeout, and
    transactions that really begin where SQLAlchemy begins them (BEGIN IMMEDIATE: the driver's own implicit
    transactions would let an answer's insert and the rater's update commit separately)."""
    sqlite = url.startswith("sqlite")
    try:
        engine = create_engine(url, connect_args={"timeout": 30, "check_same_thread": False} if sqlite else {})
    except (ArgumentError, NoSuchModuleError, ImportError) as exc:
        raise UserError(f"--db {url!r} is not a database URL this installation can open ({exc})") from None
    if sqlite:
        @event.listens_for(engine, "connect")
        def _pragmas(conn, _record):            # noqa: ANN001 (DBAPI connection)
            conn.isolation_level = None          # the driver issues no BEGIN / COMMIT of its own
            cur = conn.cursor()
            cur.execute("PRAGMA journal_mode=WAL")
            cur.execute("PRAGMA synchronous=NORMAL")   # WAL: committed answers survive a crash of the server
            cur.close()

        @event.listens_for(engine, "begin")
        def _begin(conn):                        # noqa: ANN001
            conn.exec_driver_sql("BEGIN IMMEDIATE")
    try:
        metadata.create_all(engine)
    except OperationalError as exc:
        raise UserError(f"cannot open the database {url!r}: {exc.orig}") from None
    return engine


def _state(conn, rater: int) -> RaterState | None:
    row = conn.execute(select(raters).where(raters.c.id == rater)).mappings().first()
    if row is None:
        return None
    n = conn.execute(select(func.count()).select_from(answers).where(answers.c.rater == rater)).scalar_one()
    return RaterState(row["id"], row["session"], row["shown_trial"], row["shown_at"], n, row["code"])


def open_session(engine: Engine, rater: int, first_trial: int) -> RaterState:
    """A new tab (page load) for this rater: it takes the study over; an older tab's answers are refused."""
    session, now = secrets.token_urlsafe(12), time.time()
    with engine.begin() as conn:
        if _state(conn, rater) is None:
            try:
                with conn.begin_nested():
                    conn.execute(insert(raters).values(id=rater, session=session, shown_trial=first_trial,
                                                       shown_at=now, started_at=now))
            except IntegrityError:            # two first loads at once: the other inserted; take over below
                pass
        conn.execute(update(raters).where(raters.c.id == rater).values(session=session))
        return _state(conn, rater)


def answered_trials(engine: Engine, rater: int) -> set[int]:
    with engine.connect() as conn:
        return {r[0] for r in conn.execute(select(answers.c.trial).where(answers.c.rater == rater))}


def show(engine: Engine, rater: int, session: str, trial: int) -> None:
    """Record that `trial` is on the rater's screen now (time on trial counts from here); the same trial shown
    again (a reload) keeps its first time."""
    with engine.begin() as conn:
        st = _check_session(conn, rater, session)
        if st.shown_trial != trial:
            conn.execute(update(raters).where(raters.c.id == rater).values(shown_trial=trial, shown_at=time.time()))


def _check_session(conn, rater: int, session: str) -> RaterState:
    st = _state(conn, rater)
    if st is None:
        raise RequestRefused(409, "this study has not been opened yet; load the page first")
    if st.session != session:
        raise RequestRefused(409, "this study is open in another tab or window; continue there, or reload this page "
                           "to continue here")
    return st


def record(engine: Engine, rater: int, session: str, trial: int, *, choice: str | None, ratings: dict | None,
           played: bool, next_trial: int | None, n_trials: int) -> RaterState:
    """Write one answer and move the rater to `next_trial` (None: finished, a completion code is made) in one
    transaction. Refuses (409) an answer from an old tab, for a trial that is not the one on screen, or for a
    trial already answered."""
    now = time.time()
    with engine.begin() as conn:
        st = _check_session(conn, rater, session)
        if st.code is not None:
            raise RequestRefused(409, "this study is already complete; thank you")
        if trial != st.shown_trial:
            raise RequestRefused(409, f"trial {trial} is not the one on your screen (trial {st.shown_trial}); "
                               "reload the page to continue")
        try:
            conn.execute(insert(answers).values(
                rater=rater, trial=trial, choice=choice, ratings=json.loads(json.dumps(ratings)) if ratings
                else None, seconds=max(0.0, now - st.shown_at), played=bool(played), created_at=now))
        except IntegrityError:                   # the whole transaction rolls back: nothing is written
            raise RequestRefused(409, f"trial {trial} was already answered; it counts once") from None
        values: dict = dict(shown_trial=next_trial if next_trial is not None else n_trials, shown_at=now)
        if next_trial is None:
            values.update(code=secrets.token_hex(4).upper(), completed_at=now)
        conn.execute(update(raters).where(raters.c.id == rater).values(**values))
    return RaterState(rater, session, values["shown_trial"], now, st.answered + 1, values.get("code"))


def shown_trial(engine: Engine, rater: int) -> int:
    """The furthest trial this rater has been shown (-1 before the page was first opened)."""
    with engine.connect() as conn:
        row = conn.execute(select(raters.c.shown_trial).where(raters.c.id == rater)).first()
    return -1 if row is None else int(row[0])


def all_answers(engine: Engine) -> list[dict]:
    with engine.connect() as conn:
        return [dict(r) for r in conn.execute(select(answers).order_by(answers.c.rater, answers.c.trial)).mappings()]


__all__ = ["RequestRefused", "RaterState", "all_answers", "answered_trials", "default_url", "open_db", "open_session",
           "record", "show", "shown_trial"]
