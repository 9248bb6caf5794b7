"""kernels.choice on a machine's first runs and in one-shot processes: measuring is bounded per process (a shape
with no time left takes the default and is measured later, not stored as measured), the first measurement says so
in one line on stderr, and a fast path read from the cache pays for its one-time cost (tracing, weight reorders)
before it is taken. Timings are injected (a fake `compare`), so every test is deterministic on any machine."""
from __future__ import annotations

import json
import math

import pytest
import torch
import torch.nn as nn

from gesturelsm import kernels
from gesturelsm.kernels import accelerate, cache, choice, traced_or_eager


class FakeCompare:
    """(default, fast, once) seconds, fixed; counts the measurements and charges `cost` seconds of measuring."""

    def __init__(self, default: float, fast: float, once: float = 0.0, cost: float = 0.0, clock=None):
        self.times, self.calls, self.cost, self.clock = (default, fast, once), 0, cost, clock

    def __call__(self, default_fn, fast_fn, repeats: int = choice.REPEATS, limit: float = float("inf")):
        self.calls += 1
        default_fn(), fast_fn()
        if self.clock is not None:
            self.clock[0] += self.cost
        return self.times


@pytest.fixture
def fake_clock(monkeypatch):
    """choice's wall clock (time.perf_counter as choice sees it) under the test's control."""
    now = [100.0]

    class Clock:
        @staticmethod
        def perf_counter():
            return now[0]

        thread_time = perf_counter

    monkeypatch.setattr(choice, "time", Clock)
    return now


def pair():
    return (lambda: None), (lambda: None)


def test_the_first_measurement_says_so_in_one_line(measuring, monkeypatch, capfd):
    monkeypatch.setattr(choice, "compare", FakeCompare(2.0, 1.0))
    assert kernels.taken("linear", ("a",), pair)
    assert kernels.taken("linear", ("b",), pair)
    err = capfd.readouterr().err
    lines = [x for x in err.splitlines() if "timing the fast CPU kernels" in x]
    assert len(lines) == 1 and str(measuring) in lines[0] and lines[0] == kernels.told()


def test_nothing_is_said_when_every_choice_comes_from_the_cache(measuring, monkeypatch, capfd):
    monkeypatch.setattr(choice, "compare", FakeCompare(2.0, 1.0))
    kernels.taken("linear", ("a",), pair)
    capfd.readouterr()
    choice.forget()                                              # a later process
    monkeypatch.setattr(choice, "compare", lambda *a, **k: pytest.fail("measured again"))
    assert kernels.taken("linear", ("a",), pair)
    assert "timing" not in capfd.readouterr().err and kernels.told() is None


def test_measuring_stops_at_the_budget_and_the_rest_waits_for_later(measuring, monkeypatch, fake_clock):
    """Each measurement costs 0.4 s of wall time; the budget is 1 s + 10 % of the run: three shapes are measured
    at once, the fourth takes the default (not stored), and is measured once the run has gone on long enough."""
    fake = FakeCompare(2.0, 1.0, cost=0.4, clock=fake_clock)
    monkeypatch.setattr(choice, "compare", fake)
    monkeypatch.setenv("GESTURELSM_KERNELS_BUDGET", "1")
    got = [kernels.taken("linear", (k,), pair) for k in "abcd"]
    assert got == [True, True, True, False] and fake.calls == 3
    stored = cache.read(measuring)[cache.machine_key(torch.get_num_threads())]
    assert sorted(stored) == ["linear a", "linear b", "linear c"]           # d is not decided
    assert not kernels.taken("linear", ("d",), pair) and fake.calls == 3   # still no time
    fake_clock[0] += 10.0                                                    # 10 s later: 1 s more allowed
    assert kernels.taken("linear", ("d",), pair) and fake.calls == 4
    assert "linear d" in cache.read(measuring)[cache.machine_key(torch.get_num_threads())]


def test_a_budget_of_0_measures_nothing(measuring, monkeypatch):
    monkeypatch.setenv("GESTURELSM_KERNELS_BUDGET", "0")
    monkeypatch.setattr(choice, "compare", lambda *a, **k: pytest.fail("measured"))
    assert not kernels.taken("linear", ("a",), pair)
    assert kernels.choices() == [] and not measuring.exists()


def test_the_one_time_cost_is_kept_with_the_choice(measuring, monkeypatch):
    monkeypatch.setattr(choice, "compare", FakeCompare(0.003, 0.002, once=0.05))
    assert kernels.taken("linear", ("a",), pair)                          # measured here: its cost is paid
    entry = cache.read(measuring)[cache.machine_key(torch.get_num_threads())]["linear a"]
    assert entry == {"taken": True, "ratio": 1.5, "once": 0.05, "saving": pytest.approx(0.001)}


@pytest.mark.parametrize("once,saving,want", [(0.05, 0.001, 50), (0.0, 0.001, 0), (0.001, 0.01, 1)])
def test_a_cached_fast_path_is_taken_once_it_has_paid_for_its_one_time_cost(measuring, monkeypatch, once,
                                                                           saving, want):
    """Fake timings: a path saving `saving` s per call with a one-time cost `once` s. A one-shot process that
    reads it from the cache takes the default for the first once / saving calls (what they would have saved pays
    for the one-time cost), then the fast path: a short run never pays for what it cannot win back."""
    monkeypatch.setattr(choice, "compare", FakeCompare(0.003, 0.003 - saving, once=once))
    kernels.taken("linear", ("a",), pair)
    choice.forget()                                                       # the next process
    runs = [kernels.taken("linear", ("a",), pair) for _ in range(want + 3)]
    assert runs == [False] * want + [True] * 3
    [made] = kernels.choices()
    assert made.source == "cache" and made.break_even() == want


def test_an_old_cache_entry_without_one_time_cost_is_taken_at_once(measuring, monkeypatch):
    measuring.write_text(json.dumps({"version": 1, "machines": {cache.machine_key(torch.get_num_threads()): {
        "linear a": {"taken": True, "ratio": 2.0}}}}))
    assert kernels.taken("linear", ("a",), pair)


class Tiny(nn.Module):
    def __init__(self):
        super().__init__()
        torch.manual_seed(0)
        self.a = nn.Linear(8, 8)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return torch.relu(self.a(x))


def test_a_cached_trace_is_recorded_only_once_it_pays_off(measuring, monkeypatch):
    """The trunk's trace costs 0.3 s to record and saves 0.1 s a call: a process reading that choice runs the
    module as it is for 3 calls, then records and replays the trace; results agree throughout."""
    monkeypatch.setenv("GESTURELSM_KERNELS", "measure")
    monkeypatch.setattr(choice, "compare", FakeCompare(0.2, 0.1, once=0.3))
    model = accelerate(Tiny())
    x = torch.randn(4, 8)
    with torch.no_grad():
        assert isinstance(traced_or_eager(model, (x,), "tiny"), torch.jit.ScriptModule)   # measured: recorded
        choice.forget()
        recorded = []
        real_trace = torch.jit.trace
        monkeypatch.setattr(torch.jit, "trace", lambda *a, **k: recorded.append(1) or real_trace(*a, **k))
        run = traced_or_eager(model, (x,), "tiny")
        want = model(x)
        for i in range(5):
            assert torch.allclose(run(x), want, atol=1e-6)
            assert len(recorded) == (1 if i >= 3 else 0)
    assert [c.break_even() for c in kernels.choices() if c.path == "trace"] == [3]
    assert not math.isnan(kernels.choices()[0].ratio)


def test_choices_nested_in_a_long_measurement_count_against_the_budget(measuring, monkeypatch, fake_clock):
    """A trace's warm-up runs the module, whose products ask for their own choices: once the measurement in
    progress has used the budget, they take the default instead of being measured inside it."""
    monkeypatch.setenv("GESTURELSM_KERNELS_BUDGET", "1")
    inner = []

    def outer_pair():
        def default():
            fake_clock[0] += 2.0                                          # a long first call
            inner.append(kernels.taken("linear", ("inner",), pair))
        return default, (lambda: None)

    monkeypatch.setattr(choice, "compare", FakeCompare(2.0, 1.0))
    assert kernels.taken("trace", ("trunk",), outer_pair)
    assert inner == [False]
    assert [c.key for c in kernels.choices()] == ["trace trunk"]          # the product was not measured


@pytest.mark.parametrize("entry", [{"taken": True, "ratio": 2.0, "once": "a lot"},
                                   {"taken": True, "ratio": 2.0, "once": -1.0, "saving": 0.1},
                                   {"taken": True, "ratio": 2.0, "saving": True}])
def test_a_damaged_one_time_cost_reads_as_no_entry(measuring, monkeypatch, entry):
    measuring.write_text(json.dumps({"version": 1, "machines": {cache.machine_key(torch.get_num_threads()): {
        "linear a": entry}}}))
    fake = FakeCompare(1.0, 2.0)
    monkeypatch.setattr(choice, "compare", fake)
    assert not kernels.taken("linear", ("a",), pair) and fake.calls == 1          # measured again


def test_a_measurement_that_would_not_fit_the_time_left_is_deferred(monkeypatch, fake_clock):
    """compare projects its cost from the default's first call: 1 s a call cannot be measured in 5 s (8 calls at
    least), so the fast side is never run (no trace recorded); with 9.5 s the rounds are cut to fit (8 s left after
    the warm-up calls, 2 s a round projected from the default's call: 4 rounds instead of 7)."""
    monkeypatch.setattr(choice, "clock", lambda: fake_clock[0])
    ran = []

    def side(name, cost):
        def call():
            ran.append(name)
            fake_clock[0] += cost
        return call

    with pytest.raises(choice.Deferred):
        choice.compare(side("default", 1.0), side("fast", 0.5), limit=5.0)
    assert ran == ["default"]
    ran.clear()
    t_default, t_fast, _ = choice.compare(side("default", 1.0), side("fast", 0.5), limit=9.5)
    assert (t_default, t_fast) == (1.0, 0.5)
    assert ran.count("default") == 1 + 4 and ran.count("fast") == 1 + 4     # warm-up + the rounds that fit


def test_a_deferred_measurement_takes_the_default_and_is_not_kept(measuring, monkeypatch):
    def deferring(*a, **k):
        raise choice.Deferred

    monkeypatch.setattr(choice, "compare", deferring)
    assert not kernels.taken("linear", ("a",), pair)
    assert kernels.choices() == [] and not measuring.exists()
    monkeypatch.setattr(choice, "compare", FakeCompare(2.0, 1.0))
    assert kernels.taken("linear", ("a",), pair)                             # asked again later: measured


@pytest.mark.parametrize("ahead,want", [(40, [True] * 40), (20, [False] * 20)])
def test_known_work_ahead_decides_a_cached_path_at_its_start(measuring, monkeypatch, ahead, want):
    """A path costing 0.05 s once and saving 0.0025 s a call (break-even after 20 calls): work that announces 40
    calls saves 0.1 s, PAYBACK (2) times the cost, and takes it from its first call; work of 20 calls would only
    break even and takes the default throughout, even past the 20th call, where counting alone would switch."""
    monkeypatch.setattr(choice, "compare", FakeCompare(0.005, 0.0025, once=0.05))
    kernels.taken("linear", ("a",), pair)
    choice.forget()
    with kernels.expect(ahead):
        runs = [kernels.taken("linear", ("a",), pair) for _ in range(ahead)]
    assert runs == want


def test_work_after_enough_calls_takes_the_cached_path_from_its_start(measuring, monkeypatch):
    """A long-lived process (a server): requests too short to pay alone add up; once the calls made have passed
    the break-even point, the next request takes the path from its first call, and keeps it."""
    monkeypatch.setattr(choice, "compare", FakeCompare(0.005, 0.0025, once=0.05))
    kernels.taken("linear", ("a",), pair)
    choice.forget()
    requests = []
    for _ in range(4):
        with kernels.expect(8):
            requests.append([kernels.taken("linear", ("a",), pair) for _ in range(8)])
    assert requests == [[False] * 8, [False] * 8, [False] * 8, [True] * 8]          # 24 calls made >= 20


def test_a_cached_trace_is_recorded_at_once_for_work_that_pays_for_it(measuring, monkeypatch):
    monkeypatch.setenv("GESTURELSM_KERNELS", "measure")
    monkeypatch.setattr(choice, "compare", FakeCompare(0.2, 0.1, once=0.3))
    model = accelerate(Tiny())
    x = torch.randn(4, 8)
    with torch.no_grad():
        traced_or_eager(model, (x,), "tiny")
        choice.forget()
        recorded = []
        real_trace = torch.jit.trace
        monkeypatch.setattr(torch.jit, "trace", lambda *a, **k: recorded.append(1) or real_trace(*a, **k))
        run = traced_or_eager(model, (x,), "tiny")
        with kernels.expect(6):                                          # saves 0.6 s = 2 x 0.3 s
            run(x)
        assert recorded == [1]
