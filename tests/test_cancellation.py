"""One cancellation family and one token (gesturelsm/errors.py): every cancellation the package raises is a
`Cancellation` (told to a person: `Cancelled`, a GestureError; raised inside the work: `Interrupted`, which no
`except Exception` takes), the old names are the same classes, and a `CancelToken` stops the cluster runner and a
run made ahead (the sweep's and the render's are in tests/evaluation/test_sweep.py and tests/render/test_cancel.py).
"""
from __future__ import annotations

import threading

import pytest

from gesturelsm.cluster import Job, Stopped, Unit, run_units
from gesturelsm.errors import Cancellation, CancelToken, Cancelled, GestureError, Interrupted

import _cluster_support as units


def test_one_family_with_the_old_names_in_it():
    from gesturelsm.evaluation.sweep import SweepCancelled
    from gesturelsm.render.background import RenderCancelled
    from gesturelsm.serve.ahead import Cancelled as AheadCancelled
    from gesturelsm.webapp.closing import PageClosed

    assert issubclass(Cancelled, GestureError) and issubclass(Cancelled, Cancellation)
    assert issubclass(Interrupted, Cancellation) and not issubclass(Interrupted, Exception)
    assert SweepCancelled is Cancelled and RenderCancelled is Cancelled and Stopped is Cancelled
    assert AheadCancelled is Interrupted and PageClosed is Interrupted


def test_a_token_keeps_its_first_reason_and_follows_the_others_it_was_made_with():
    token = CancelToken()
    assert not token.cancelled and not token() and token.wait(0) is False
    token.check()                                            # nothing while it is wanted
    assert token.cancel("superseded") and not token.cancel("closed")
    assert token.cancelled and token.is_set() and token() and token.reason == "superseded" and token.wait(0)
    with pytest.raises(Interrupted, match="superseded"):
        token.check()
    with pytest.raises(Cancelled, match="said to a person"):
        token.check(Cancelled, "said to a person")
    closed = [False]
    child = CancelToken(token, None)
    other = CancelToken(lambda: closed[0])
    assert child.cancelled and child.reason == "superseded"  # its parent's
    assert not other.cancelled and other.wait(0.05) is False
    closed[0] = True
    assert other.wait(5) and other.reason == "cancelled"
    assert CancelToken.of(token) is token and not CancelToken.of(None).cancelled and CancelToken.of(lambda: True)()


def test_interrupted_passes_through_a_methods_own_error_handling():
    token = CancelToken()
    token.cancel("the click asked for other settings")
    recorded = []

    def each_method():
        for method in ("a", "b"):
            try:
                token.check()                               # a window's progress report
            except Exception as exc:                        # a method's failure: recorded, the next one made
                recorded.append(exc)
            yield method
    with pytest.raises(Interrupted):
        list(each_method())
    assert recorded == []


def test_a_cancelled_token_stops_the_cluster_runner_between_units():
    token, done = CancelToken(), []

    def finished(unit, result):
        done.append(unit.key)
        token.cancel()
    with pytest.raises(Cancelled, match="Stopped on request"):
        run_units(Job(units.work, units.build, 0), [Unit("a", 1), Unit("b", 2)], finished, cancelled=token)
    assert done == ["a"]


def test_a_cancelled_token_stops_a_run_made_ahead_at_its_next_check():
    from gesturelsm.serve.ahead import Ahead

    ahead, started = Ahead(), threading.Event()

    def make(run):
        while True:                                          # a method's windows, each reporting progress
            try:
                run.check()
            except Exception:                                # a method's own error handling
                pytest.fail("an Exception handler took the cancellation")
            started.set()
            run.cancelled.wait(1.0)
            yield from ()

    run = ahead.start("key", make)
    assert run is not None and started.wait(30)
    ahead.cancel()
    run.thread.join(30)
    assert not run.thread.is_alive() and run.done and run.failed and run.cancelled.cancelled
