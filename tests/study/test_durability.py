"""What the study server does when its answers database fails under it: an answer is acknowledged only once it is
stored where the study keeps it, so a deleted, replaced or read-only database is refused at once (a JSON error the
page shows, nothing acknowledged), a write lock held by another program gives a quick JSON error without stalling
pages and videos, and a missing or read-only database stops the server at startup with one clear line."""
from __future__ import annotations

import os
import shutil
import sqlite3
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import pytest

from _study_support import make_synthetic_study
from gesturelsm.errors import UserError


@pytest.fixture
def folder(tmp_path):
    return make_synthetic_study(tmp_path / "study", methods=("alpha", "beta"), raters=2, attention=0.5)


def _rater(folder, rid=1):
    from gesturelsm.study.design import read_raters

    return next(r for r in read_raters(folder).values() if r.id == rid)


def _client(folder, url=None, **kw):
    from starlette.testclient import TestClient

    from gesturelsm.study.server import Study, build_app

    return TestClient(build_app(Study.open(folder, url)), **kw)


def _answer(c, token, session, trial):
    return c.post(f"/api/{token}/answer", json=dict(session=session, trial=trial, choice="left", played=True))


def _stored(folder):
    """(rater, trial) of every answer in the study's database file, read as `study results` would."""
    con = sqlite3.connect(f"file:{folder / 'responses.sqlite'}?mode=ro", uri=True)
    try:
        return sorted(con.execute("SELECT rater, trial FROM answers").fetchall())
    finally:
        con.close()


@pytest.mark.parametrize("removed", ["every file", "the database file", "the write-ahead log"])
def test_answers_are_refused_once_the_database_is_deleted(folder, removed):
    rater = _rater(folder)
    c = _client(folder, raise_server_exceptions=False)
    session = c.post(f"/api/{rater.token}/open").json()["session"]
    assert _answer(c, rater.token, session, 0).status_code == 200
    suffixes = {"every file": ("", "-wal", "-shm"), "the database file": ("",), "the write-ahead log": ("-wal",)}
    for s in suffixes[removed]:
        (folder / f"responses.sqlite{s}").unlink()
    r = _answer(c, rater.token, session, 1)
    assert r.status_code == 503 and "not saved" in r.json()["error"].lower()
    again = _answer(c, rater.token, session, 1)                  # the rater tries again: still refused
    assert again.status_code == 503 and "not saved" in again.json()["error"].lower()
    opened = c.post(f"/api/{rater.token}/open")
    assert opened.status_code == 503 and opened.json()["error"]


def test_a_restart_on_a_missing_database_is_a_clear_error(folder, capsys):
    from gesturelsm.cli import main

    rater = _rater(folder)
    c = _client(folder)
    session = c.post(f"/api/{rater.token}/open").json()["session"]
    assert _answer(c, rater.token, session, 0).status_code == 200
    for f in folder.glob("responses.sqlite*"):
        f.unlink()
    with pytest.raises(UserError, match="missing"):
        _client(folder)
    assert main(["study", "results", str(folder)]) == 2        # not "no answers yet": they existed
    assert "missing" in capsys.readouterr().err
    assert not (folder / "responses.sqlite").exists()           # nothing was made in its place


def test_a_replaced_database_is_refused(folder, tmp_path):
    rater = _rater(folder)
    c = _client(folder, raise_server_exceptions=False)
    session = c.post(f"/api/{rater.token}/open").json()["session"]
    assert _answer(c, rater.token, session, 0).status_code == 200
    other = tmp_path / "other.sqlite"
    shutil.copy(folder / "responses.sqlite", other)
    os.replace(other, folder / "responses.sqlite")               # the same name, another file
    r = _answer(c, rater.token, session, 1)
    assert r.status_code == 503 and "not saved" in r.json()["error"].lower()


def test_a_read_only_database_is_refused_while_serving_and_at_startup(folder):
    rater = _rater(folder)
    c = _client(folder, raise_server_exceptions=False)
    session = c.post(f"/api/{rater.token}/open").json()["session"]
    db_file = folder / "responses.sqlite"
    db_file.chmod(0o444)
    try:
        r = _answer(c, rater.token, session, 0)
        assert r.status_code == 503 and "read-only" in r.json()["error"]
        assert _stored(folder) == []
        with pytest.raises(UserError, match="read-only"):
            _client(folder)
    finally:
        db_file.chmod(0o644)
    assert _answer(c, rater.token, session, 0).status_code == 200   # writable again: answers are taken again
    assert _stored(folder) == [(1, 0)]


def test_a_write_lock_held_elsewhere_gives_a_json_error_and_stalls_no_video(folder, monkeypatch):
    """Another program holds the database's write lock until both requests are answered (or 20 s pass): the
    answer must come back refused while the lock is still held, and the video must not wait for it."""
    from starlette.testclient import TestClient

    from gesturelsm.study import server
    from gesturelsm.study.server import Study, build_app

    writing = threading.Event()                      # the answer's write has begun (it waits for the lock)

    def record(*args, **kw):
        writing.set()
        return original(*args, **kw)
    original = server._record
    monkeypatch.setattr(server, "_record", record)
    rater = _rater(folder)
    with TestClient(build_app(Study.open(folder)), raise_server_exceptions=False) as c:   # one event loop
        session = c.post(f"/api/{rater.token}/open").json()["session"]
        holder = sqlite3.connect(folder / "responses.sqlite", isolation_level=None, timeout=5, check_same_thread=False)
        holder.execute("BEGIN IMMEDIATE")
        done: dict[str, float] = {}
        released = threading.Event()

        def timed(name, fn):
            out = fn()
            done[name] = time.monotonic()
            return out

        def release_after_both_or_20s():
            t_end = time.monotonic() + 20
            while len(done) < 2 and time.monotonic() < t_end:
                time.sleep(0.02)
            done["released"] = time.monotonic()
            holder.execute("ROLLBACK")
            released.set()

        threading.Thread(target=release_after_both_or_20s, daemon=True).start()
        with ThreadPoolExecutor(2) as pool:
            fa = pool.submit(timed, "answer", lambda: _answer(c, rater.token, session, 0))
            assert writing.wait(60), "the answer never began its write"
            fv = pool.submit(timed, "video", lambda: c.get(f"/api/{rater.token}/video/0/left"))
            a, v = fa.result(), fv.result()
        released.wait(30)
        holder.close()
        assert a.status_code == 503 and "busy" in a.json()["error"]
        assert v.status_code == 200 and v.content[4:8] == b"ftyp"
        assert done["answer"] < done["released"] and done["video"] < done["released"]
        assert _answer(c, rater.token, session, 0).status_code == 200     # the lock is gone: the same answer goes in
    assert _stored(folder) == [(1, 0)]


def test_every_storage_failure_is_documented():
    """docs/STUDY.md says what happens to answers on each failure the server reports."""
    from pathlib import Path

    from gesturelsm.study.store import FAILURES

    doc = (Path(__file__).resolve().parents[2] / "docs" / "STUDY.md").read_text()
    section = doc[doc.index("## When the database fails"):]
    for name in FAILURES:
        assert f"| {name} |" in section, name
