"""Motion made ahead of the click (gesturelsm/serve/ahead.py), on tiny checkpoints: the click that asks for the
settings the run was made for shows exactly the motion a fresh request makes, without making it again (also while
the run is still being made); a click for other settings cancels the run and makes its own; no run starts while the
server generates or is busy; what a broken run did not make, the click makes."""
from __future__ import annotations

import logging
import shutil
import threading

import numpy as np
import pytest

from gesturelsm.serve.request import Request

from _support import until

ALL = ("gesturelsm", "rectified_flow", "ddim")
STEPS = {"gesturelsm": 3, "rectified_flow": 1, "ddim": 2}


@pytest.fixture
def upload(speech_wav, tmp_path):
    """A file of its own (a new upload: nothing prepared or made for it yet)."""
    return str(shutil.copy(speech_wav, tmp_path / "upload.wav"))


@pytest.fixture
def calls(service, monkeypatch):
    """Every `GesturePipeline.generate` call: (thread name, method); no run of another test still going."""
    service.ahead.stop(60)
    seen = []
    generate = service.pipeline.generate

    def counted(*a, **k):
        seen.append((threading.current_thread().name, k.get("method")))
        return generate(*a, **k)
    monkeypatch.setattr(service.pipeline, "generate", counted)
    yield seen
    service.ahead.stop(60)


def _request(path, **kw) -> Request:
    return Request(path, methods=ALL, steps=dict(STEPS), transcribe=False, exports=False, render=False, **kw)


def _ahead(service, req):
    """The prefetch the page sends on an upload, and the run it started."""
    assert service.prefetch(req.audio_path, "", None, False, ahead=req)
    run = service.ahead._run
    assert run is not None and run.key == service.motion_key(*service.check(req))
    return run


def _fresh(service, req):
    """The request's motions made the usual way (no run made ahead)."""
    service.ahead.cancel()
    return service.run(req).motions


def test_the_click_shows_the_motion_made_ahead_without_making_it_again(service, upload, calls):
    req = _request(upload)
    run = _ahead(service, req)
    run.thread.join(60)
    assert [m for _, m in calls] == ["rectified_flow", "ddim", "gesturelsm"]          # made ahead, fastest first
    assert {t for t, _ in calls} == {"gesturelsm-ahead"}
    results = list(service.stream(req))
    assert len(calls) == 3 and run.taken                                              # the click made nothing
    assert list(results[-1].motions) == list(ALL) and results[-1].pending == ()
    assert [list(r.motions) for r in results] == [list(ALL)]                   # all made: shown in one result
    assert "Made ahead" in results[-1].summary
    fresh = _fresh(service, req)
    assert len(calls) == 6                                                             # a run is taken once
    assert "Made ahead" not in service.run(req).summary
    for m in ALL:
        np.testing.assert_array_equal(results[-1].motions[m].poses, fresh[m].poses)
        np.testing.assert_array_equal(results[-1].motions[m].trans, fresh[m].trans)


def _gated(service, monkeypatch, after: int):
    """Hold the run made ahead after its `after`-th method until the returned event is set."""
    gate, made = threading.Event(), []
    generate = service.pipeline.generate

    def held(*a, **k):
        if threading.current_thread().name == "gesturelsm-ahead":
            if len(made) >= after:
                assert gate.wait(60)
            made.append(k.get("method"))
        return generate(*a, **k)
    monkeypatch.setattr(service.pipeline, "generate", held)
    return gate


def _open_after_take(service, monkeypatch, gate) -> dict:
    """Open the gate the moment the click has asked for the run (taken or not); what the run was then."""
    take, seen = service.ahead.take, {}

    def taking(key):
        out = take(key)
        run = service.ahead._run
        seen.update(taken=out is not None, done=run.done, made=len(run.made))
        gate.set()
        return out
    monkeypatch.setattr(service.ahead, "take", taking)
    return seen


def test_a_click_takes_a_run_still_being_made(service, upload, calls, monkeypatch):
    gate = _gated(service, monkeypatch, after=1)
    req = _request(upload)
    seen = _open_after_take(service, monkeypatch, gate)
    run = _ahead(service, req)
    results = list(service.stream(req))
    assert seen == {"taken": True, "done": False, "made": seen["made"]} and seen["made"] <= 1   # still being made
    assert run.taken and run.done and not run.failed
    assert sorted(m for _, m in calls) == sorted(ALL)                           # each method made once, ahead
    assert {t for t, _ in calls} == {"gesturelsm-ahead"}
    fresh = _fresh(service, req)
    for m in ALL:
        np.testing.assert_array_equal(results[-1].motions[m].poses, fresh[m].poses)


def test_a_click_for_other_settings_cancels_the_run_and_makes_its_own(service, upload, calls, monkeypatch, caplog):
    gate = _gated(service, monkeypatch, after=1)
    seen = _open_after_take(service, monkeypatch, gate)
    run = _ahead(service, _request(upload, seed=0))
    other = _request(upload, seed=1)
    with caplog.at_level(logging.INFO, logger="gesturelsm.app"):
        shown = service.run(other).motions
        run.thread.join(60)
    assert seen["taken"] is False and seen["done"] is False
    assert run.cancelled.is_set() and run.failed and not run.taken and len(run.made) < len(ALL)
    assert any("cancelled" in r.getMessage() for r in caplog.records)
    assert sorted(m for t, m in calls if t != "gesturelsm-ahead") == sorted(ALL)    # the click made its own
    fresh = _fresh(service, other)
    for m in ALL:
        np.testing.assert_array_equal(shown[m].poses, fresh[m].poses)
    assert not np.array_equal(shown["gesturelsm"].poses, _fresh(service, _request(upload, seed=0))["gesturelsm"].poses)


def test_no_run_starts_while_the_server_generates_or_is_busy(service, upload, calls, monkeypatch):
    req = _request(upload)
    with service.ahead.generating():
        assert service.make_ahead(req) is None
    monkeypatch.setattr(service.ahead, "busy", lambda: True)
    assert service.make_ahead(req) is None
    monkeypatch.setattr(service.ahead, "busy", lambda: False)
    from dataclasses import replace

    from gesturelsm.serve.service import GestureService

    off = GestureService(service.pipeline, replace(service.settings, ahead=False), service.body)   # --no-ahead
    assert off.prefetch(upload, "", None, False, ahead=req) and off.ahead._run is None
    run = service.make_ahead(req)
    assert run is not None and service.make_ahead(req) is None                     # the same settings: one run
    run.thread.join(60)
    assert calls and {t for t, _ in calls} == {"gesturelsm-ahead"}


def test_a_run_stops_when_something_else_needs_the_cores(service, upload, calls, monkeypatch):
    gate = _gated(service, monkeypatch, after=1)
    run = _ahead(service, _request(upload))
    until(lambda: run.made, "the first method was made ahead")   # the second held
    monkeypatch.setattr(run, "busy", lambda: True)                 # e.g. a live stream opened meanwhile
    gate.set()
    run.thread.join(60)
    assert run.cancelled.is_set() and run.failed and len(run.made) == 1


def test_what_a_broken_run_did_not_make_the_click_makes(service, upload):
    from gesturelsm.serve.ahead import Run
    from gesturelsm.serve.progressive import _made

    req, plan = service.check(_request(upload))
    _, speech, _ = service.speech(req, None, lambda f, m: None)
    first = next(service.pipeline.generate_each(speech, plan, body=service.body))
    run = Run("key")
    run.add(first)
    run.finish(failed=True)                                         # e.g. an error of the server's after one method
    made = list(_made(service, plan, speech, run, lambda f, m: None))
    assert sorted(x.method for x in made) == sorted(ALL) and made[0] is first


def test_settings_a_request_would_refuse_start_nothing(service, upload):
    from gesturelsm.errors import InputError

    before = service.ahead._run
    with pytest.raises(InputError, match="Seed"):
        service.make_ahead(_request(upload, seed=-5))
    assert service.prefetch(upload, "", None, False, ahead=_request(upload, seed=-5)) is True     # speech prepared
    assert service.ahead._run is before


@pytest.mark.parametrize("change", [dict(seed=1), dict(cfg=1.5), dict(steps={**STEPS, "ddim": 3}),
                                    dict(methods=("gesturelsm", "ddim")), dict(grounding=False),
                                    dict(stand_in_place=True), dict(smoothing="off"), dict(text="hello there"),
                                    dict(transcribe=True)])
def test_every_setting_that_changes_the_motion_changes_its_key(service, upload, change):
    from dataclasses import replace

    base = _request(upload)
    key = service.motion_key(*service.check(base))
    assert service.motion_key(*service.check(replace(base, **change))) != key
    for same in (dict(size=512), dict(exports=True), dict(render=True)):           # what is only shown or written
        assert service.motion_key(*service.check(replace(base, **same))) == key


def test_a_request_left_unfinished_does_not_stop_runs_for_good(service, upload, calls):
    req = _request(upload)
    stream = service.stream(req)
    next(stream)                                                   # the page went away after the first result
    assert service.ahead._requests == 1 and service.make_ahead(_request(upload, seed=3)) is None
    stream.close()
    assert service.ahead._requests == 0
    assert service.make_ahead(_request(upload, seed=3)) is not None
