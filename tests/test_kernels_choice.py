"""kernels.choice and kernels.cache: a fast path is taken only where it was measured faster by the margin, the
measurement alternates sides and takes medians, choices round-trip through the cache file keyed by CPU, torch and
thread count, a damaged file is ignored, GESTURELSM_KERNELS forces choices and GESTURELSM_ONEDNN=0 the default.
Timings are injected (a fake `compare` or a fake clock), so every test is deterministic on any machine."""
from __future__ import annotations

import json

import pytest
import torch
import torch.nn as nn
import torch.nn.functional as F
from torch.profiler import profile

from gesturelsm import kernels
from gesturelsm.kernels import FastConv1d, accelerate, cache, choice, linear, onednn_linear_available, traced_or_eager

needs_onednn = pytest.mark.skipif(not onednn_linear_available(),
                                  reason="this PyTorch build has no working oneDNN linear op")
ONEDNN_OP = "mkldnn::_linear_pointwise"


def ops_run(fn) -> set[str]:
    with profile() as p:
        fn()
    return {e.key for e in p.key_averages()}


class FakeCompare:
    """Stands in for choice.compare: reports fixed (default, fast) seconds and counts the measurements."""

    def __init__(self, default: float, fast: float):
        self.times, self.calls = (default, fast), 0

    def __call__(self, default_fn, fast_fn, repeats: int = choice.REPEATS, limit: float = float("inf")):
        self.calls += 1
        default_fn(), fast_fn()                         # both must run on the real tensors
        return self.times


def product():
    g = torch.Generator().manual_seed(0)
    return torch.randn(96, 64, generator=g), torch.randn(48, 64, generator=g), torch.randn(48, generator=g)


def test_tests_force_choices_and_keep_no_cache_file():
    """The suite itself never measures (conftest): results cannot depend on this machine's timings."""
    assert choice.forced() is not None
    assert cache.cache_path() is None


@needs_onednn
@pytest.mark.parametrize("default,fast,want", [(2.0, 1.0, True), (1.0, 2.0, False), (1.0, 0.97, False)])
def test_a_path_is_taken_only_where_measured_faster_by_the_margin(measuring, monkeypatch, default, fast, want):
    fake = FakeCompare(default, fast)
    monkeypatch.setattr(choice, "compare", fake)
    x, w, b = product()
    with torch.no_grad():
        linear(x, w, b)                                                     # measured here (both sides run)
        assert (ONEDNN_OP in ops_run(lambda: linear(x, w, b))) == want      # decided once, kept
        assert torch.allclose(linear(x, w, b), F.linear(x, w, b), rtol=1e-5, atol=1e-5)
    assert fake.calls == 1
    [made] = kernels.choices()
    assert (made.path, made.key, made.taken, made.source) == ("linear", "linear 128x64->48 bias", want, "measured")
    assert made.ratio == pytest.approx(default / fast)


def test_a_convolution_measured_slower_stays_in_the_default_layout(measuring, monkeypatch):
    monkeypatch.setattr(choice, "compare", FakeCompare(1.0, 3.0))
    torch.manual_seed(0)
    plain = nn.Conv1d(6, 8, 5, padding=2)
    fast = accelerate(nn.Sequential(nn.Conv1d(6, 8, 5, padding=2)))[0]
    fast.load_state_dict(plain.state_dict())
    assert type(fast) is FastConv1d
    x = torch.randn(3, 6, 40)
    with torch.no_grad():
        y = fast(x)
        assert torch.equal(y, plain(x)) and y.is_contiguous()              # the default's call, exactly
    monkeypatch.setattr(choice, "compare", FakeCompare(3.0, 1.0))
    with torch.no_grad():
        z = fast(torch.randn(3, 6, 200))                                    # another length: measured again
    assert not z.is_contiguous()                                            # a view of channels-last memory
    assert [c.taken for c in kernels.choices()] == [False, True]


def test_compare_alternates_sides_and_takes_medians(monkeypatch):
    """A fake clock advances by each call's scripted cost: one huge outlier per side must not move the result,
    and the side that goes first alternates between rounds."""
    now, order = [0.0], []
    costs = {"default": iter([5.0, 2.0, 2.1, 1.9, 50.0, 2.0, 2.2, 2.0]),
             "fast": iter([5.0, 1.0, 40.0, 1.1, 0.9, 1.0, 1.0, 1.2])}

    def call(side: str):
        def run():
            order.append(side)
            now[0] += next(costs[side])
        return run

    monkeypatch.setattr(choice, "clock", lambda: now[0])
    t_default, t_fast, once = choice.compare(call("default"), call("fast"), repeats=7)
    assert (t_default, t_fast) == (pytest.approx(2.0), pytest.approx(1.0))
    assert once == pytest.approx((5.0 - 1.0) - (5.0 - 2.0))          # the fast side's first call, beyond the default's
    rounds = [tuple(order[i:i + 2]) for i in range(2, len(order), 2)]      # after the two warm-up calls
    assert rounds == [("default", "fast"), ("fast", "default")] * 3 + [("default", "fast")]


@needs_onednn
def test_choices_round_trip_through_the_cache_and_another_cpu_measures_again(measuring, monkeypatch):
    fake = FakeCompare(2.0, 1.0)
    monkeypatch.setattr(choice, "compare", fake)
    x, w, b = product()
    with torch.no_grad():
        linear(x, w, b)
    assert fake.calls == 1
    stored = json.loads(measuring.read_text())["machines"]
    [(machine, section)] = stored.items()
    assert section == {"linear 128x64->48 bias": {"taken": True, "ratio": 2.0}}
    assert machine == cache.machine_key(torch.get_num_threads())

    choice.forget()                                       # a new process on the same machine: read, not measured
    monkeypatch.setattr(choice, "compare", FakeCompare(1.0, 2.0))
    with torch.no_grad():
        assert ONEDNN_OP in ops_run(lambda: linear(x, w, b))
    assert [(c.source, c.taken) for c in kernels.choices()] == [("cache", True)]

    choice.forget()                                       # another CPU: that section is not read
    monkeypatch.setattr(cache, "cpu_identity", lambda: ("Other CPU", "fpu sse2 avx2"))
    other = FakeCompare(1.0, 2.0)
    monkeypatch.setattr(choice, "compare", other)
    with torch.no_grad():
        linear(x, w, b)
        assert ONEDNN_OP not in ops_run(lambda: linear(x, w, b))
    assert other.calls == 1 and [(c.source, c.taken) for c in kernels.choices()] == [("measured", False)]
    assert len(json.loads(measuring.read_text())["machines"]) == 2          # both machines kept


@needs_onednn
def test_another_thread_count_or_torch_version_is_another_key(measuring, monkeypatch):
    key = cache.machine_key(1)
    assert key != cache.machine_key(2)
    monkeypatch.setattr(torch, "__version__", "0.0.0-other")
    assert cache.machine_key(1) != key


@pytest.mark.parametrize("content", ["{not json", "", "[1, 2]", '{"version": 99, "machines": {}}',
                                     '{"version": 1, "machines": {"MACHINE": {"linear 128x64->48 bias": '
                                     '{"taken": "yes", "ratio": 2}}}}',
                                     '{"version": 1, "machines": {"MACHINE": [1]}}'])
@needs_onednn
def test_a_damaged_cache_file_is_ignored_and_replaced(measuring, monkeypatch, content):
    measuring.write_text(content.replace("MACHINE", cache.machine_key(torch.get_num_threads())))
    fake = FakeCompare(1.0, 2.0)
    monkeypatch.setattr(choice, "compare", fake)
    x, w, b = product()
    with torch.no_grad():
        assert torch.equal(linear(x, w, b), F.linear(x, w, b))
    assert fake.calls == 1                                # measured, as with no file
    assert cache.read(measuring)[cache.machine_key(torch.get_num_threads())]["linear 128x64->48 bias"]["taken"] is False


@needs_onednn
def test_an_unwritable_cache_location_keeps_choices_in_memory(measuring, monkeypatch, tmp_path):
    blocker = tmp_path / "a file"
    blocker.write_text("")
    monkeypatch.setenv("GESTURELSM_KERNELS_CACHE", str(blocker / "kernels.json"))   # its folder is a file
    fake = FakeCompare(2.0, 1.0)
    monkeypatch.setattr(choice, "compare", fake)
    x, w, b = product()
    with torch.no_grad():
        linear(x, w, b)
        linear(x, w, b)
    assert fake.calls == 1 and kernels.choices()[0].taken


def test_a_fast_side_that_fails_means_the_default_and_is_not_stored(measuring):
    def refuse():
        raise RuntimeError("a private op refused this input")

    assert not kernels.taken("linear", ("odd shape",), lambda: ((lambda: None), refuse))
    assert not kernels.taken("linear", ("odd shape",), lambda: pytest.fail("measured twice"))
    assert [(c.source, c.taken) for c in kernels.choices()] == [("failed", False)]
    assert not measuring.exists()                        # nothing written: another process may measure it again


@needs_onednn
def test_gesturelsm_onednn_0_forces_the_default_whatever_was_measured(measuring, monkeypatch):
    monkeypatch.setattr(choice, "compare", FakeCompare(9.0, 1.0))
    monkeypatch.setenv("GESTURELSM_ONEDNN", "0")
    x, w, b = product()
    with torch.no_grad():
        assert ONEDNN_OP not in ops_run(lambda: linear(x, w, b))
        assert torch.equal(linear(x, w, b), F.linear(x, w, b))
        plain = nn.Sequential(nn.Conv1d(6, 8, 5, padding=2), nn.ReLU(), nn.Linear(40, 7))
        fast = accelerate(nn.Sequential(nn.Conv1d(6, 8, 5, padding=2), nn.ReLU(), nn.Linear(40, 7)))
        fast.load_state_dict(plain.state_dict())
        xs = torch.randn(2, 6, 40)
        assert torch.equal(fast(xs), plain(xs))
    assert kernels.choices() == []                        # nothing was even measured


@needs_onednn
@pytest.mark.parametrize("value,want", [("none", False), ("linear", True), ("conv,trace", False), ("all", True)])
def test_gesturelsm_kernels_forces_a_choice_without_measuring(monkeypatch, value, want):
    monkeypatch.setenv("GESTURELSM_KERNELS", value)
    monkeypatch.setattr(choice, "compare", FakeCompare(1.0, 9.0))
    x, w, b = product()
    with torch.no_grad():
        assert (ONEDNN_OP in ops_run(lambda: linear(x, w, b))) == want
    assert kernels.choices() == []


def test_an_unknown_forced_path_is_named_in_a_warning(monkeypatch):
    monkeypatch.setenv("GESTURELSM_KERNELS", "linear,warp_drive")
    with pytest.warns(UserWarning, match="warp_drive"):
        assert choice.forced() == frozenset({"linear"})


class Tiny(nn.Module):
    def __init__(self):
        super().__init__()
        torch.manual_seed(0)
        self.a, self.b = nn.Linear(16, 32), nn.Linear(32, 8)

    def forward(self, x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
        return self.b(torch.relu(self.a(x)) * y)


@pytest.mark.parametrize("faster", [True, False])
def test_the_trunk_is_traced_only_where_the_trace_was_measured_faster(measuring, monkeypatch, faster):
    monkeypatch.setattr(choice, "compare", FakeCompare(2.0, 1.0) if faster else FakeCompare(1.0, 2.0))
    model = accelerate(Tiny())
    args = (torch.randn(5, 16), torch.randn(5, 32))
    with torch.no_grad():
        run = traced_or_eager(model, args, "tiny")
        assert isinstance(run, torch.jit.ScriptModule) == faster and (run is model) != faster
        assert torch.allclose(run(*args), Tiny()(*args), rtol=1e-5, atol=1e-6)
    trace_choice = [c for c in kernels.choices() if c.path == "trace"]
    assert [c.key for c in trace_choice] == ["trace tiny (5, 16) (5, 32)"]


@needs_onednn
def test_a_trace_records_onednn_products(monkeypatch):
    """oneDNN's product cannot be recorded by the tracer as an op call; through its TorchScript wrapper it is."""
    monkeypatch.setenv("GESTURELSM_KERNELS", "linear,trace")
    model = accelerate(Tiny())
    args = (torch.randn(5, 16), torch.randn(5, 32))
    with torch.no_grad():
        run = traced_or_eager(model, args, "tiny")
        assert isinstance(run, torch.jit.ScriptModule)
        assert ONEDNN_OP in ops_run(lambda: run(*args))
        assert torch.allclose(run(*args), Tiny()(*args), rtol=1e-5, atol=1e-6)
