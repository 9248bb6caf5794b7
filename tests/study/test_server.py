"""The study server over a synthetic study folder, driven through HTTP (Starlette's test client): a rater's whole
run, refusals of bad input that record nothing, Range requests for videos, and answers kept across a restart."""
from __future__ import annotations

import json

import pytest


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    from _study_support import make_synthetic_study

    return make_synthetic_study(tmp_path_factory.mktemp("srv") / "study", raters=3)


def _client(folder, db_url, **kw):
    from starlette.testclient import TestClient

    from gesturelsm.study.server import Study, build_app

    return TestClient(build_app(Study.open(folder, db_url)), **kw)


def _tokens(folder):
    from gesturelsm.study.design import read_raters

    return {r.id: r for r in read_raters(folder).values()}


def test_a_rater_completes_the_study_and_answers_survive_a_restart(folder, tmp_path):
    from gesturelsm.study import db

    url = f"sqlite:///{tmp_path / 'r.sqlite'}"
    rater = _tokens(folder)[1]
    c = _client(folder, url)
    page = c.get(f"/r/{rater.token}")
    assert page.status_code == 200 and 'id="trial"' in page.text
    for secret in ("alpha", "beta", "gamma", "v_", ".mp4", "conditions"):      # nothing that unblinds
        assert secret not in page.text
    st = c.post(f"/api/{rater.token}/open").json()
    n = len(rater.trials)
    assert (st["n"], st["k"], st["trial"]["index"], st["code"]) == (n, 0, 0, None)
    shown = json.dumps({k: v for k, v in st.items() if k != "session"})    # the session token is random text
    assert "alpha" not in shown and "v_" not in shown
    half = n // 2
    for i in range(half):
        st2 = c.post(f"/api/{rater.token}/answer", json=dict(session=st["session"], trial=i, choice="left",
                                                             played=True)).json()
        assert st2["k"] == i + 1 and (st2["trial"] or {}).get("index") == i + 1
    c2 = _client(folder, url)                                    # the server restarts: a reload resumes
    st = c2.post(f"/api/{rater.token}/open").json()
    assert (st["k"], st["trial"]["index"]) == (half, half)
    session = st["session"]
    for i in range(half, n):
        st = c2.post(f"/api/{rater.token}/answer", json=dict(session=session, trial=i, choice="right",
                                                             played=True)).json()
    assert st["k"] == n and st["trial"] is None and len(st["code"]) == 8
    again = c2.post(f"/api/{rater.token}/open").json()           # the finished study shows the same code
    assert again["code"] == st["code"] and again["trial"] is None
    rows = db.all_answers(db.open_db(url))
    assert [(r["rater"], r["trial"]) for r in rows] == [(1, i) for i in range(n)]
    assert [r["choice"] for r in rows] == ["left"] * half + ["right"] * (n - half)
    assert all(r["played"] and r["seconds"] >= 0 for r in rows)


def test_bad_requests_are_refused_with_a_message_and_record_nothing(folder, tmp_path):
    from gesturelsm.study import db

    url = f"sqlite:///{tmp_path / 'r.sqlite'}"
    rater = _tokens(folder)[2]
    c = _client(folder, url)
    t = rater.token
    r = c.get("/r/not-a-token")
    assert r.status_code == 404 and "not valid" in r.text
    assert c.post("/api/not-a-token/open").status_code == 404
    s1 = c.post(f"/api/{t}/open").json()["session"]

    def answer(body, raw=None):
        r = c.post(f"/api/{t}/answer", content=raw) if raw is not None else c.post(f"/api/{t}/answer", json=body)
        return r.status_code, r.json().get("error", "")

    assert answer(None, b"{not json")[0] == 400
    assert answer(None, b"[1, 2]")[0] == 400
    assert answer(None, b"x" * 10000)[0] == 413
    assert answer(dict(session=s1, trial="0", choice="left"))[0] == 400          # trial must be a number
    assert answer(dict(session=s1, trial=0, choice="maybe"))[0] == 400
    assert answer(dict(session=s1, trial=0, choice="left", played="yes"))[0] == 400
    assert answer(dict(session=s1, trial=99, choice="left"))[0] == 400
    code, msg = answer(dict(session=s1, trial=1, choice="left"))                 # not shown to this rater yet
    assert code == 409 and "not the one on your screen" in msg
    assert c.get(f"/api/{t}/video/1/left").status_code == 404                    # nor are its videos
    assert db.all_answers(db.open_db(url)) == []
    ok = c.post(f"/api/{t}/answer", json=dict(session=s1, trial=0, choice="none", played=True))
    assert ok.status_code == 200
    code, msg = answer(dict(session=s1, trial=0, choice="none", played=True))    # a replay of the same request
    assert code == 409
    s2 = c.post(f"/api/{t}/open").json()["session"]                              # a second tab takes over
    code, msg = answer(dict(session=s1, trial=1, choice="left", played=True))
    assert code == 409 and "another tab" in msg
    assert answer(dict(session=s2, trial=1, choice="right", played=True))[0] == 200
    rows = db.all_answers(db.open_db(url))
    assert [(r["trial"], r["choice"]) for r in rows] == [(0, "none"), (1, "right")]


def test_videos_stream_with_range_requests_only_for_shown_trials(folder, tmp_path):
    rater = _tokens(folder)[3]
    c = _client(folder, f"sqlite:///{tmp_path / 'r.sqlite'}")
    assert c.get(f"/api/{rater.token}/video/0/left").status_code == 404          # before the page opened
    c.post(f"/api/{rater.token}/open")
    full = c.get(f"/api/{rater.token}/video/0/left")
    assert full.status_code == 200 and full.headers["content-type"] == "video/mp4"
    assert full.content == (folder / "videos" / rater.trials[0].left).read_bytes()
    assert "content-disposition" not in full.headers                             # no file name leaks
    part = c.get(f"/api/{rater.token}/video/0/right", headers={"Range": "bytes=100-199"})
    assert part.status_code == 206 and part.content == (folder / "videos" / rater.trials[0].right).read_bytes()[100:200]
    assert c.get(f"/api/{rater.token}/video/0/up").status_code == 404


def test_two_servers_on_one_database_count_a_doubled_answer_once(folder, tmp_path):
    from gesturelsm.study import db

    url = f"sqlite:///{tmp_path / 'r.sqlite'}"
    rater = _tokens(folder)[1]
    one, two = _client(folder, url), _client(folder, url)
    session = one.post(f"/api/{rater.token}/open").json()["session"]
    body = dict(session=session, trial=0, choice="left", played=True)
    codes = sorted(c.post(f"/api/{rater.token}/answer", json=body).status_code for c in (one, two))
    assert codes == [200, 409]
    assert [(r["rater"], r["trial"]) for r in db.all_answers(db.open_db(url))] == [(1, 0)]


def test_video_headers_carry_nothing_that_orders_or_links_videos(folder, tmp_path):
    """No modification time (it orders methods by render time and marks the attention-check videos as the newest)
    and no validator shared by two trials (the same ETag in two trials gives away a reused video)."""
    from gesturelsm.study import db

    url = f"sqlite:///{tmp_path / 'r.sqlite'}"
    rater = _tokens(folder)[1]
    c = _client(folder, url)
    session = c.post(f"/api/{rater.token}/open").json()["session"]
    allowed = {"content-type", "content-length", "content-range", "accept-ranges", "cache-control", "date",
               "server"}
    seen: dict[str, list[tuple[int, str]]] = {}
    for t in rater.trials:
        for side in ("left", "right"):
            for headers in ({}, {"Range": "bytes=0-99"}):
                r = c.get(f"/api/{rater.token}/video/{t.index}/{side}", headers=headers)
                assert r.status_code in (200, 206)
                assert set(r.headers) <= allowed, set(r.headers) - allowed
            seen.setdefault(t.left if side == "left" else t.right, []).append((t.index, side))
        c.post(f"/api/{rater.token}/answer", json=dict(session=session, trial=t.index, choice="left", played=True))
    assert any(len(v) > 1 for v in seen.values())        # a video shown in two trials was among those checked
    assert len(db.all_answers(db.open_db(url))) == len(rater.trials)


@pytest.mark.parametrize("body, expect", [
    (b'{"session": "s", "trial": 0, "choice": "left", "x": ' + b"[" * 2000 + b"]" * 2000 + b"}", "nested"),
    (b'{"session": "s", "trial": ' + b"9" * 4000 + b', "choice": "left"}', "too long"),
])
def test_hostile_json_gets_a_400_with_a_message(folder, tmp_path, body, expect):
    rater = _tokens(folder)[2]
    c = _client(folder, f"sqlite:///{tmp_path / 'r.sqlite'}", raise_server_exceptions=False)
    c.post(f"/api/{rater.token}/open")
    r = c.post(f"/api/{rater.token}/answer", content=body, headers={"Content-Type": "application/json"})
    assert r.status_code == 400 and expect in r.json()["error"]


def test_a_video_trial_of_5000_digits_is_a_404_with_a_message(folder, tmp_path):
    rater = _tokens(folder)[2]
    c = _client(folder, f"sqlite:///{tmp_path / 'r.sqlite'}", raise_server_exceptions=False)
    c.post(f"/api/{rater.token}/open")
    for trial in ("9" * 5000, "-1", "1.5", "٣"):
        r = c.get(f"/api/{rater.token}/video/{trial}/left")
        assert r.status_code == 404 and r.json()["error"], trial
