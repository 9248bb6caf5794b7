"""Responses in a database through SQLAlchemy: SQLite in the study folder by default, any SQLAlchemy URL
(e.g. postgresql://...) for a hosted study.

Tables
    raters   one row per rater who opened their link: the tab (session) that holds the study now, which trial
             was last shown and when (for time on trial), the completion code once every trial is answered
    answers  one row per (rater, trial), unique: rater, trial, choice (left / right / none, or the ratings as
             JSON), seconds on the trial (from when the server showed it), whether both videos were played to
             the end, when it was written
    identity one row: the database's own random id (the study folder remembers it, so a database that went
             missing or was swapped is noticed: store.py), when it was made and last opened for writing

Every answer is one transaction: the answer row and the rater's next trial are written together or not at all;
a second submission of the same trial breaks the unique constraint and is refused, so nothing counts twice.
SQLite: write transactions take the write lock when they begin (BEGIN IMMEDIATE), reads do not wait for it (WAL);
connections open the file without creating it, so a database deleted under the server is not silently made anew.
"""
from __future__ import annotations

import json
import secrets
import sqlite3
import time
from dataclasses import dataclass
from pathlib import Path

from sqlalchemy import (JSON, Boolean, Column, Float, ForeignKey, Integer, MetaData, String, Table,
                        UniqueConstraint, create_engine, event, func, inspect, insert, select, update)
from sqlalchemy.engine import Engine, make_url
from sqlalchemy.exc import ArgumentError, DBAPIError, IntegrityError, NoSuchModuleError

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
identity = Table(
    "identity", metadata,
    Column("id", String(32), primary_key=True),
    Column("created_at", Float, nullable=False),
    Column("opened_at", Float, nullable=False),
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


def sqlite_file(url: str) -> Path | None:
    """The file of an SQLite URL (None for other databases and in-memory SQLite)."""
    try:
        u = make_url(url)
    except ArgumentError:
        return None
    if not u.get_backend_name() == "sqlite" or not u.database or u.database == ":memory:":
        return None
    name = u.database
    if u.query.get("uri") in ("true", "1") and name.startswith("file:"):
        name = name[len("file:"):].split("?", 1)[0]
    return Path(name).resolve()


def open_db(url: str, *, create: bool = True, busy_timeout: float = 30.0) -> Engine:
    """An engine on `url` with the tables created (`create`; otherwise a missing SQLite file is a UserError and
    nothing is made). SQLite gets WAL (readers do not wait for the writer), synchronous=FULL (a committed answer
    is on disk before it is acknowledged), `busy_timeout` seconds of waiting for another writer's lock, and
    write transactions that really begin where SQLAlchemy begins them (the driver's own implicit transactions
    would let an answer's insert and the rater's update commit separately)."""
    path = sqlite_file(url)
    try:
        if path is not None:
            engine = _sqlite_engine(url, path, create, busy_timeout)
        else:
            engine = create_engine(url)
    except (ArgumentError, NoSuchModuleError, ImportError) as exc:
        raise UserError(f"--db {url!r} is not a database URL this installation can open ({exc})") from None
    if create:
        try:
            metadata.create_all(engine)
        except DBAPIError as exc:
            raise UserError(f"cannot open the database {url!r}: {exc.orig}") from None
    return engine


def _sqlite_engine(url: str, path: Path, create: bool, busy_timeout: float) -> Engine:
    if not path.exists():
        if not create:
            raise UserError(f"there is no database at {path}")
        if not path.parent.is_dir():
            raise UserError(f"cannot make the database {path}: its folder does not exist")
        try:
            sqlite3.connect(path).close()
        except sqlite3.Error as exc:
            raise UserError(f"cannot make the database {path}: {exc}") from None
    target = f"{path.as_uri()}?mode=rw"

    def connect():
        return sqlite3.connect(target, uri=True, timeout=busy_timeout, check_same_thread=False)

    engine = create_engine(url, creator=connect)

    @event.listens_for(engine, "connect")
    def _pragmas(conn, _record):            # DBAPI connection
        conn.isolation_level = None          # the driver issues no BEGIN / COMMIT of its own
        cur = conn.cursor()
        cur.execute("PRAGMA journal_mode=WAL")
        cur.execute("PRAGMA synchronous=FULL")
        cur.close()

    @event.listens_for(engine, "begin")
    def _begin(conn):
        opts = conn.get_execution_options()
        conn.exec_driver_sql(f"PRAGMA busy_timeout = {int(1000 * opts.get('lock_wait', busy_timeout))}")
        conn.exec_driver_sql("BEGIN IMMEDIATE" if opts.get("write") else "BEGIN")
    return engine


def writing(engine: Engine) -> Engine:
    """The engine for write transactions: on SQLite they take the write lock at BEGIN, so two writers never
    both read a state and then find the lock taken when they write."""
    return engine.execution_options(write=True)


def waiting(engine: Engine, seconds: float) -> Engine:
    """The engine whose transactions wait at most `seconds` for a lock another connection holds (SQLite)."""
    return engine.execution_options(lock_wait=max(0.0, seconds))


def has_tables(engine: Engine) -> bool:
    """Whether the database holds the study's tables (a database nobody answered into may not)."""
    return inspect(engine).has_table("answers")


def claim_identity(engine: Engine, expected: str | None) -> tuple[str, bool]:
    """(the database's id, whether it was made just now). The id is made when the database has none and nothing
    is `expected`; with an `expected` id and none in the database, nothing is written and ("", True) returned.
    An existing id's opened_at is rewritten: a write that proves the database takes writes."""
    now = time.time()
    with writing(engine).begin() as conn:
        row = conn.execute(select(identity.c.id)).first()
        if row is None:
            if expected:
                return "", True
            new = secrets.token_hex(8)
            conn.execute(insert(identity).values(id=new, created_at=now, opened_at=now))
            return new, True
        conn.execute(update(identity).where(identity.c.id == row[0]).values(opened_at=now))
        return row[0], False


def _state(conn, rater: int) -> RaterState | None:
    row = conn.execute(select(raters).where(raters.c.id == rater)).mappings().first()
    if row is None:
        return None
    n = conn.execute(select(func.count()).select_from(answers).where(answers.c.rater == rater)).scalar_one()
    return RaterState(row["id"], row["session"], row["shown_trial"], row["shown_at"], n, row["code"])


def open_session(engine: Engine, rater: int, first_trial: int) -> RaterState:
    """A new tab (page load) for this rater: it takes the study over; an older tab's answers are refused."""
    session, now = secrets.token_urlsafe(12), time.time()
    with writing(engine).begin() as conn:
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
    with writing(engine).begin() as conn:
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
    with writing(engine).begin() as conn:
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
    """Every answer, by rater and trial (none from a database that holds no study tables)."""
    if not has_tables(engine):
        return []
    with engine.connect() as conn:
        return [dict(r) for r in conn.execute(select(answers).order_by(answers.c.rater, answers.c.trial)).mappings()]


__all__ = ["RequestRefused", "RaterState", "all_answers", "answered_trials", "claim_identity", "default_url",
           "has_tables", "open_db", "open_session", "record", "show", "shown_trial", "sqlite_file", "waiting",
           "writing"]
