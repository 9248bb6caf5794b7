"""The study server's answers database, kept honest: an answer is acknowledged only once it is stored where the
study keeps it, and database work never runs on the server's event loop.

- Identity. The study folder remembers the id of the database its answers go to (`key/database.json`, one entry
  per database; the id lives in the database's `identity` table). Starting on a database that went missing (a
  deleted SQLite file, an emptied server database) or that is another one than before is a UserError; so is a
  database that takes no writes (read-only file, read-only file system, no permission): nothing waits for the
  first answer to find out.
- While serving (SQLite files): before and after every write the file, its write-ahead log and its shared-memory
  index must still be the very files the server opened (device and inode) and the file must still be writable;
  after an answer is committed, a fresh connection reads it back from the file. A deleted or replaced database
  stops all writes until the server is restarted; a read-only one refuses writes while it stays read-only.
- Off the event loop. Writes run one at a time on their own thread, reads on a small pool, each with a deadline;
  SQLite waits `busy_timeout` seconds for a write lock another program holds, then the answer is refused with a
  message the page shows (`RequestRefused`, HTTP 503) and the rater can send it again.

FAILURES holds what a rater is told for each failure (`message`); docs/STUDY.md says what happens to the answers
in each.
"""
from __future__ import annotations

import asyncio
import json
import os
import sqlite3
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Callable

from sqlalchemy.engine import Engine, make_url
from sqlalchemy.exc import DBAPIError, SQLAlchemyError

from ..errors import UserError
from . import db
from .db import RequestRefused

BUSY_TIMEOUT = 0.5           # s waited for a write lock held by another program before an answer is refused
MIN_WAIT = 0.05             # s any write waits for a lock at least
DEADLINE = 10.0              # s a request waits for the database at most (queue included)
READERS = 4
FAILURES = {           # why a write was refused, as the rater is told (after what it means for them: ACTIONS)
    "deleted": "the study's database was deleted while the study ran; please tell the study's organiser",
    "replaced": "the study's database was replaced by another file while the study ran; please tell the study's "
                "organiser",
    "read-only": "the study's database is read-only; please tell the study's organiser",
    "busy": "the study's database is busy (another program holds it); please try again in a moment",
    "late": "the study's database did not answer in time; reload the page to see where you are",
    "failed": "the study's database failed; please try again, or tell the study's organiser",
}
ACTIONS = {"answer": "your answer was NOT saved", "open": "the study cannot be opened just now"}
UNREADABLE = "the study's database cannot be read just now; please try again in a moment"
MARKER = Path("key") / "database.json"
SIDE_FILES = ("-wal", "-shm")


class Unstored(RequestRefused):
    """A write the database did not take (or may not have taken): `kind` is a key of FAILURES."""

    def __init__(self, kind: str):
        super().__init__(503, FAILURES[kind])
        self.kind = kind


def message(kind: str, action: str) -> str:
    """What the rater is told when `action` ("answer" | "open") meets failure `kind`."""
    if kind == "late" and action == "answer":
        return f"your answer may not have been saved: {FAILURES[kind]}"
    return f"{ACTIONS[action]}: {FAILURES[kind]}"


def _identity(path: Path) -> tuple[int, int] | None:
    try:
        st = path.stat()
    except FileNotFoundError:
        return None
    return st.st_dev, st.st_ino


def writable(path: Path) -> bool:
    """Whether `path` may be written: by this process, and by anyone (a file nobody may write is read-only by
    intent, also for root, whom the permission bits do not stop)."""
    try:
        return os.access(path, os.W_OK) and bool(path.stat().st_mode & 0o222)
    except FileNotFoundError:
        return False


def marker_key(url: str | None) -> str:
    """How the study folder names a database: the default SQLite file by its name (the folder may move), any
    other URL without its password."""
    return "responses.sqlite" if url is None else make_url(url).render_as_string(hide_password=True)


def read_markers(folder: Path) -> dict[str, dict]:
    path = folder / MARKER
    try:
        return json.loads(path.read_text()) if path.exists() else {}
    except ValueError:
        raise UserError(f"{path} is damaged (not JSON); it names the databases this study's answers are in") from None


def _write_marker(folder: Path, key: str, entry: dict) -> None:
    markers = read_markers(folder)
    markers[key] = entry
    tmp = folder / MARKER.with_suffix(".json.tmp")
    tmp.parent.mkdir(parents=True, exist_ok=True)
    tmp.write_text(json.dumps(markers, indent=1) + "\n")
    os.replace(tmp, folder / MARKER)


def missing_message(where: str, entry: dict) -> str:
    made = time.strftime("%Y-%m-%d %H:%M", time.localtime(entry.get("created_at", 0)))
    return (f"the answers database {where} is missing: this study stored answers in it (database {entry['id']}, "
            f"made {made}). Restore it from a backup; to start the study over with an empty database, remove its "
            f"entry from {MARKER}")


class Store:
    """The answers database of one running study server."""

    def __init__(self, engine: Engine, url: str, log: Callable[[str], None] = print,
                 busy_timeout: float = BUSY_TIMEOUT):
        self.engine, self.url, self.log, self.busy_timeout = engine, url, log, busy_timeout
        self.file = db.sqlite_file(url)
        self.broken: str | None = None                   # a deleted or replaced database: no more writes
        self._ids: dict[str, tuple[int, int] | None] = {}
        self._keeper: sqlite3.Connection | None = None
        self._writer = ThreadPoolExecutor(1, "study-db-write")
        self._readers = ThreadPoolExecutor(READERS, "study-db-read")
        if self.file is not None:
            # one connection held open for the server's life keeps the log and index files from being removed
            # and made anew (SQLite removes them when its last connection closes), so their identity holds
            self._keeper = sqlite3.connect(f"{self.file.as_uri()}?mode=rw", uri=True, check_same_thread=False)
            self._keeper.execute("SELECT count(*) FROM identity").fetchone()
            self._ids = {s: _identity(self._path(s)) for s in ("", *SIDE_FILES)}

    @classmethod
    def open(cls, folder: str | Path, url: str | None = None, log: Callable[[str], None] = print,
             busy_timeout: float = BUSY_TIMEOUT) -> "Store":
        """The database of the study in `folder` (`url`: None is STUDY/responses.sqlite), checked: not missing,
        not another database than the one the study's answers are in, taking writes."""
        folder = Path(folder)
        full = url or db.default_url(folder)
        key = marker_key(url)
        entry = read_markers(folder).get(key)
        file = db.sqlite_file(full)
        where = str(file) if file is not None else key
        if file is not None and entry and not file.exists():
            raise UserError(missing_message(where, entry))
        engine = db.open_db(full, busy_timeout=busy_timeout)
        if file is not None and not writable(file):
            raise UserError(f"the answers database {where} is read-only; make it writable (answers could not be "
                            "saved)")
        try:
            got, _ = db.claim_identity(engine, entry["id"] if entry else None)
        except DBAPIError as exc:
            raise UserError(f"the answers database {where} takes no writes ({exc.orig}); answers could not be "
                            "saved") from None
        if entry and not got:
            raise UserError(missing_message(where, entry))
        if entry and got != entry["id"]:
            raise UserError(f"the answers database {where} is another database (id {got}) than the one this "
                            f"study's answers are in ({entry['id']}); restore that one, or to go on with this one "
                            f"remove its entry from {MARKER}")
        if not entry:
            _write_marker(folder, key, dict(id=got, created_at=time.time()))
        return cls(engine, full, log, busy_timeout)

    def _path(self, suffix: str) -> Path:
        return self.file.with_name(self.file.name + suffix)

    def _fail(self, kind: str, detail: str) -> Unstored:
        if kind in ("deleted", "replaced"):
            if self.broken is None:
                self.log(f"ANSWERS ARE NOT BEING SAVED: {detail}. Every answer is refused until the server is "
                         "restarted on the study's database.")
            self.broken = kind
        else:
            self.log(f"write refused: {detail}")
        return Unstored(kind)

    def check(self) -> None:
        """Refuse (503) unless the database is still the files the server opened, and writable."""
        if self.broken:
            raise Unstored(self.broken)
        if self.file is None:
            return
        for suffix in ("", *SIDE_FILES):
            was, now = self._ids.get(suffix), _identity(self._path(suffix))
            name = self._path(suffix)
            if was is None:
                self._ids[suffix] = now
            elif now is None:
                raise self._fail("deleted", f"{name} was deleted")
            elif now != was:
                raise self._fail("replaced", f"{name} was replaced by another file")
        if not writable(self.file):
            raise self._fail("read-only", f"{self.file} is read-only")

    def verify(self, rater: int, trial: int, created_at: float) -> None:
        """Read a committed answer back from the database file through a fresh connection."""
        if self.file is None:
            return
        try:
            con = sqlite3.connect(f"{self.file.as_uri()}?mode=ro", uri=True, timeout=self.busy_timeout)
            try:
                row = con.execute("SELECT created_at FROM answers WHERE rater = ? AND trial = ?",
                                  (rater, trial)).fetchone()
            finally:
                con.close()
        except sqlite3.Error as exc:
            what = f"the answer of rater {rater}, trial {trial} could not be read back from {self.file} ({exc})"
            if "locked" in str(exc) or "busy" in str(exc):     # committed, most likely: the rater reloads to see
                raise self._fail("late", what) from None
            raise self._fail("deleted", what) from None
        if row is None or row[0] != created_at:
            raise self._fail("replaced", f"the answer of rater {rater}, trial {trial} is not in {self.file} after "
                                         "its commit")

    def _guarded(self, fn: Callable, arrived: float, *args, **kw):
        waited = time.monotonic() - arrived
        if waited > DEADLINE:                            # waited in the queue past the request's deadline
            raise Unstored("busy")
        self.check()
        # a lock held elsewhere is waited for busy_timeout from the request's arrival, so writes queued behind
        # one that waits for it do not each wait as long again (MIN_WAIT: a brief lock of another writer)
        engine = db.waiting(self.engine, max(MIN_WAIT, self.busy_timeout - waited))
        try:
            out = fn(engine, *args, **kw)
        except DBAPIError as exc:
            text = str(exc.orig).lower()
            kind = "busy" if "locked" in text or "busy" in text else "read-only" if "readonly" in text else "failed"
            raise self._fail(kind, f"{kind}: {exc.orig}") from None
        except SQLAlchemyError as exc:
            raise self._fail("failed", str(exc)) from None
        self.check()
        return out

    async def write(self, fn: Callable, *args, action: str = "answer", **kw):
        """`fn(engine, *args, **kw)` on the writer thread, between identity checks; a failure is a RequestRefused (503)
        that tells the rater what it means for their `action` ("answer" | "open")."""
        try:
            return await self._run(self._writer, Unstored("late"), self._guarded, fn, time.monotonic(), *args, **kw)
        except Unstored as exc:
            raise RequestRefused(503, message(exc.kind, action)) from None

    async def read(self, fn: Callable, *args, **kw):
        """`fn(engine, *args, **kw)` on a reader thread, with the same deadline."""
        return await self._run(self._readers, RequestRefused(503, UNREADABLE), self._read, fn, *args, **kw)

    def _read(self, fn: Callable, *args, **kw):
        try:
            return fn(self.engine, *args, **kw)
        except SQLAlchemyError as exc:
            self.log(f"read failed: {exc}")
            raise RequestRefused(503, UNREADABLE) from None

    async def _run(self, pool: ThreadPoolExecutor, late: RequestRefused, fn: Callable, *args, **kw):
        loop = asyncio.get_running_loop()
        future = loop.run_in_executor(pool, lambda: fn(*args, **kw))
        try:
            return await asyncio.wait_for(future, DEADLINE)
        except asyncio.TimeoutError:
            raise late from None

    def close(self) -> None:
        self._writer.shutdown(wait=False, cancel_futures=True)
        self._readers.shutdown(wait=False, cancel_futures=True)
        if self._keeper is not None:
            self._keeper.close()
            self._keeper = None
        self.engine.dispose()


__all__ = ["ACTIONS", "BUSY_TIMEOUT", "DEADLINE", "FAILURES", "MARKER", "Store", "Unstored", "marker_key", "message",
           "missing_message", "read_markers", "writable"]
