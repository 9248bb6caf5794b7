"""Which fast path a call takes, by measurement: each path is timed against the default on the call's own shapes.

A path (PATHS) is one family of swappable kernels. The first time a call of a given shape could take one (a
product of these sizes, a convolution of this layer on this length, the generator's trunk at these shapes), both
ways are run on that call's own tensors (a bounded slice of them), alternating, several times, and the path is
taken only when the default's median time is at least MARGIN times the fast path's. Where the two are about
equal, or the fast one is slower, the default stays. Both compute the same function (the fast paths differ from
the defaults by float summation order only), so a choice changes speed, and results only within float rounding
(a few 1e-4 rad after a sampler's repeated steps); `GESTURELSM_KERNELS=none` gives the default ops' bits.

The choice is kept for the process and on disk (cache.py), per CPU, torch build and thread count: later processes
on the same machine measure nothing. Timing: this thread's CPU time when torch runs on one thread (other
processes on a shared machine then hardly move it), wall time otherwise.

First use on a machine: measuring is bounded so that it never holds a request up for long. A process may spend
BUDGET_S seconds plus SHARE of its running time on it (GESTURELSM_KERNELS_BUDGET sets BUDGET_S; 0 measures
nothing); a shape it has no time for takes the default and is measured by a later call or process, so the cache
fills over the first runs. A measurement projected (from the default's first call) not to fit in the time left is
deferred before the fast side runs (no trace is recorded for it), and its rounds are cut to fit. The first
measurement of a process says so in one line on stderr.

One-shot processes: a fast path has one-time costs (recording a trace, reordering weights, oneDNN generating its
kernels) that a long-lived process pays once and a one-shot command pays every time. The measurement keeps them
(`once`, the fast side's first call beyond its steady time and beyond the default's first call) with the time a
call saves; a process that reads a choice from the cache takes the fast path only once the calls it has made at
that shape would have saved its one-time cost (ski rental: a short process stays on the default, a long one switches
and gains), so a one-shot command pays at most about that cost again for a path it cannot use enough. Where the
caller knows the work ahead (`expect`: a sampler's windows x steps), nothing is paid for nothing: the path is taken
at once when that work saves PAYBACK times its one-time cost, and otherwise not before the work is over (a process
whose earlier work already passed the break-even point, a server, takes it at the start of its next work).

GESTURELSM_KERNELS forces the choice instead (nothing is measured or read from disk): `all` takes every path
where it is available, `none` none, a comma list (`linear,trace`) those named. Tests set it, so they do not
depend on the machine's timings. GESTURELSM_ONEDNN=0 turns every fast module off, whatever GESTURELSM_KERNELS says
(ops.fast_path).
"""
from __future__ import annotations

import math
import os
import statistics
import sys
import threading
import time
import warnings
from contextlib import contextmanager
from dataclasses import dataclass
from functools import lru_cache
from typing import Callable, Hashable, Iterator

import torch

from . import cache

PATHS = {
    "linear": "fp32 products (and a fused exact GELU) through oneDNN instead of MKL's sgemm",
    "conv": "1D convolutions as (1 x k) 2D ones on channels-last tensors (oneDNN) instead of PyTorch's layout",
    "conv_add": "a convolution summed straight into its residual by oneDNN instead of a new tensor and an add",
    "trace": "the generator's trunk recorded once (torch.jit.trace) instead of run op by op from Python",
}
MARGIN = 1.05        # taken when default time / fast time >= MARGIN: a tie keeps the default
REPEATS = 7          # timed rounds per side (medians), after one warm-up call each
MIN_REPEATS = 3      # ... at least this many when the time left to measure is short
MIN_ROUND_S = 2e-4   # a round repeats a short call until it lasts about this long (timer and call overhead)
BUDGET_S = 1.0       # seconds a process may spend measuring at once (GESTURELSM_KERNELS_BUDGET) ...
SHARE = 0.1          # ... plus this share of the wall time since its first choice
PAYBACK = 2.0        # known work ahead takes a cached path at once when it saves this many times its one-time cost
                     # (the measured cost undercounts: the trunk's trace costs about 1.5x it in a fresh process)

Pair = Callable[[], tuple[Callable[[], object], Callable[[], object]]]


@dataclass(frozen=True)
class Choice:
    """One decision: `path` for calls described by `key`, taken or not; `ratio` = default time / fast time;
    `source` is "measured", "cache" (read from disk) or "failed" (a side raised: the default, not stored); `cost`:
    wall seconds spent measuring it (nested choices made during its warm-up included); `once`: the fast path's
    one-time cost (seconds), `saving`: what one call saves (default time - fast time), both 0 when unknown."""
    path: str
    key: str
    taken: bool
    ratio: float
    source: str
    cost: float = 0.0
    once: float = 0.0
    saving: float = 0.0

    def break_even(self) -> int:
        """Calls at this shape after which the fast path has paid for its one-time cost in a process that did
        not measure it (0: take it at once; it is only counted for a choice read from the cache)."""
        if not self.taken or self.source != "cache" or self.once <= 0:
            return 0
        return math.ceil(self.once / max(self.saving, 1e-9)) if self.saving > 0 else sys.maxsize


_lock = threading.RLock()
_memory: dict[tuple[int, str, Hashable], Choice] = {}
_disk: dict[str, dict[str, dict]] | None = None         # the cache file's sections, read once per process
_spent = [0.0]                                          # wall seconds spent measuring in this process
_depth = [0]                                            # measurements in progress (nested ones run in warm-ups)
_switches: dict[tuple[int, str, Hashable], "Switch"] = {}   # cached choices that have to pay off first
_ahead = threading.local()                              # .work: (token, calls) of the caller's `expect`
_started: list[float] = []                              # when this process first asked for a choice
_outer: list[float] = [0.0]                             # when the measurement in progress (depth 1) began
_told: list[str] = []                                   # the line said when measuring began (once per process)


def clock() -> float:
    """This thread's CPU time at one math thread, else wall time (seconds)."""
    return time.thread_time() if torch.get_num_threads() == 1 else time.perf_counter()


class Deferred(Exception):
    """A measurement that would not fit in the time left to measure: the default this time, measured later."""


def compare(default: Callable[[], object], fast: Callable[[], object], repeats: int = REPEATS,
            limit: float = math.inf) -> tuple[float, float, float]:
    """Median seconds per call of default() and fast(), after one warm-up call each (first touches, lazy
    weights, nested choices), and the fast side's one-time cost: how much more its first call took beyond its
    median than the default's first call beyond its own (0 at least). Rounds alternate which side goes first, so
    drift hits both alike. `limit`: wall seconds the measurement may take; one projected to take longer (from the
    default's first call) raises Deferred before the fast side runs, and the rounds are cut to fit (MIN_REPEATS
    at least)."""
    wall0 = time.perf_counter()
    t0 = clock()
    default()
    once = clock() - t0
    wall_once = time.perf_counter() - wall0
    if wall_once * (2 + 2 * MIN_REPEATS) > limit:
        raise Deferred
    t1 = clock()
    fast()
    first_fast = clock() - t1
    n = max(1, min(64, math.ceil(MIN_ROUND_S / max(once, 1e-7))))
    left = limit - (time.perf_counter() - wall0)
    if math.isfinite(left):
        repeats = max(MIN_REPEATS, min(repeats, int(left / max(2 * n * wall_once, 1e-9))))
    times: dict[int, list[float]] = {0: [], 1: []}
    for r in range(repeats):
        for side in ((0, 1) if r % 2 == 0 else (1, 0)):
            fn = fast if side else default
            start = clock()
            for _ in range(n):
                fn()
            times[side].append((clock() - start) / n)
    t_default, t_fast = statistics.median(times[0]), statistics.median(times[1])
    return t_default, t_fast, max(0.0, (first_fast - t_fast) - (once - t_default))


@lru_cache(maxsize=8)
def _parse_forced(value: str) -> frozenset[str] | None:
    v = value.strip().lower()
    if v in ("", "measure"):
        return None
    if v == "all":
        return frozenset(PATHS)
    if v == "none":
        return frozenset()
    names = {n.strip() for n in v.split(",") if n.strip()}
    unknown = sorted(names - set(PATHS))
    if unknown:
        warnings.warn(f"GESTURELSM_KERNELS: unknown path(s) {', '.join(unknown)} ignored; known: all, none, "
                      f"measure, {', '.join(PATHS)}", stacklevel=3)
    return frozenset(names & set(PATHS))


def forced() -> frozenset[str] | None:
    """The paths GESTURELSM_KERNELS forces on (all others off), or None when choices are measured."""
    return _parse_forced(os.environ.get("GESTURELSM_KERNELS", ""))


def key_text(path: str, key: Hashable) -> str:
    """'linear 256x128->512 gelu bias': the path and the key's non-empty parts, as the cache file stores it."""
    parts = key if isinstance(key, tuple) else (key,)
    return " ".join([path, *(str(p) for p in parts if str(p))])


def budget_base() -> float:
    """GESTURELSM_KERNELS_BUDGET (seconds; 0: measure nothing), else BUDGET_S."""
    raw = os.environ.get("GESTURELSM_KERNELS_BUDGET", "").strip()
    try:
        base = float(raw) if raw else BUDGET_S
    except ValueError:
        return BUDGET_S
    return BUDGET_S if math.isnan(base) else max(0.0, base)


def budget() -> float:
    """Seconds this process may have spent measuring so far: `budget_base()` plus SHARE of the wall time since
    its first choice (0 when the base is 0)."""
    base = budget_base()
    if base <= 0:
        return 0.0
    return base + SHARE * (time.perf_counter() - _started[0] if _started else 0.0)


def taken(path: str, key: Hashable, pair: Pair) -> bool:
    """Whether calls of `path` described by `key` (shapes) take the fast path. `pair()` gives (default, fast),
    two calls on real tensors of those shapes that compute the same thing; it is called only when the choice
    has to be measured. Not measured while tracing (the default is used and nothing is recorded). A fast path
    read from the cache is taken from the call at which it has paid for its one-time cost (Choice.break_even)."""
    got = decide(path, key, pair)
    if got is None or not got.taken:
        return False
    if got.break_even() == 0:
        return True
    slot = (torch.get_num_threads(), path, key)
    if slot not in _switches:
        _switches[slot] = Switch(got)
    return _switches[slot].take()


@contextmanager
def expect(calls: int) -> Iterator[None]:
    """The work inside makes about `calls` calls at each shape it uses (a sampler: windows x steps). Cached fast
    paths with a one-time cost are then decided for the whole work at its start (Switch), not by counting calls."""
    before = getattr(_ahead, "work", None)
    _ahead.work = (object(), max(0, int(calls)))
    try:
        yield
    finally:
        _ahead.work = before


class Switch:
    """When a fast path read from the cache, with a one-time cost, starts being taken in this process. Inside an
    `expect` it is decided once per work: at once if the work ahead saves PAYBACK times the cost or the calls made
    before it have passed the break-even point, else not during that work. Outside one: ski rental, from the call
    at which the calls made would have paid for the cost (Choice.break_even)."""

    def __init__(self, choice: Choice):
        self.choice, self.need = choice, choice.break_even()
        self.calls, self.on = 0, False
        self.work: object = None
        self.verdict = False

    def take(self) -> bool:
        if self.on:
            return True
        work = getattr(_ahead, "work", None)
        if work is None:
            self.on = self.calls >= self.need
        else:
            token, ahead = work
            if token is not self.work:
                self.work = token
                self.verdict = (self.calls >= self.need
                                or ahead * self.choice.saving >= PAYBACK * self.choice.once)
            self.on = self.verdict
        if not self.on:
            self.calls += 1
        return self.on


def decide(path: str, key: Hashable, pair: Pair) -> Choice | None:
    """The choice for `path` at `key`: forced, kept, read from the cache or measured in this call (within the budget);
    None where nothing is decided yet (forced off, while tracing, or no time left to measure it this time)."""
    force = forced()
    if force is not None:
        return Choice(path, key_text(path, key), path in force, math.nan, "forced")
    threads = torch.get_num_threads()
    got = _memory.get((threads, path, key))
    if got is not None:
        return got
    if torch.jit.is_tracing():
        return None
    with _lock:
        if not _started:
            _started.append(time.perf_counter())
        got = _memory.get((threads, path, key)) or _decide(threads, path, key, pair)
    return got


def _decide(threads: int, path: str, key: Hashable, pair: Pair) -> Choice | None:
    global _disk
    machine, text = cache.machine_key(threads), key_text(path, key)
    if _disk is None:
        _disk = cache.read(cache.cache_path())
    stored = _disk.get(machine, {}).get(text)
    if stored is not None:
        choice = Choice(path, text, stored["taken"], float(stored["ratio"]), "cache",
                        once=float(stored.get("once", 0.0)), saving=float(stored.get("saving", 0.0)))
    else:
        if spent() >= budget():
            return None                           # no time left this time: the default, measured later
        _tell()
        choice = _measure(path, text, pair)
        if choice is None:
            return None                           # would not fit in the time left: measured later
        if choice.source == "measured":
            entry: dict = {"taken": choice.taken, "ratio": round(choice.ratio, 4)}
            if choice.once > 0:
                entry.update(once=round(choice.once, 6), saving=round(choice.saving, 9))
            _disk.setdefault(machine, {})[text] = entry
            cache.write(cache.cache_path(), machine, {text: entry})
    _memory[(threads, path, key)] = choice
    return choice


def _tell() -> None:
    """One line on stderr, the first time this process measures: why this run is slower than the next ones."""
    if _told:
        return
    where = cache.cache_path()
    line = ("gesturelsm: timing the fast CPU kernels on this machine (first runs here; at most "
            f"{budget_base():.1f} s + "
            f"{100 * SHARE:.0f} % of this run, the rest in later runs; kept in {where or 'memory only'})")
    _told.append(line)
    print(line, file=sys.stderr, flush=True)


def _measure(path: str, text: str, pair: Pair) -> Choice | None:
    """Time both sides, within the time left to measure (None: it would not fit); a side that fails (a private op
    refusing an unusual input) means: the default, for this process only ("failed" is not stored)."""
    start = time.perf_counter()
    if _depth[0] == 0:
        _outer[0] = start
    _depth[0] += 1
    try:
        measured = compare(*pair(), limit=max(0.0, budget() - spent()))
    except Deferred:
        return None
    except Exception:  # the default path is always a correct answer
        return Choice(path, text, False, math.nan, "failed", time.perf_counter() - start)
    finally:
        _depth[0] -= 1
        if _depth[0] == 0:
            _spent[0] += time.perf_counter() - start
    t_default, t_fast = measured[0], measured[1]
    once = float(measured[2]) if len(measured) > 2 else 0.0
    ratio = t_default / max(t_fast, 1e-12)
    return Choice(path, text, ratio >= MARGIN, ratio, "measured", time.perf_counter() - start, once,
                  max(0.0, t_default - t_fast))


def choices() -> list[Choice]:
    """Every choice this process has made or read, in the order made."""
    return list(_memory.values())


def told() -> str | None:
    """The line this process printed when it began measuring, or None."""
    return _told[0] if _told else None


def spent() -> float:
    """Wall seconds this process has spent measuring so far, the measurement in progress included."""
    return _spent[0] + (time.perf_counter() - _outer[0] if _depth[0] > 0 else 0.0)


def probe_seconds() -> float:
    """Wall seconds this process spent measuring choices (0 when all came from the cache or were forced)."""
    return _spent[0]


def forget() -> None:
    """Drop this process's choices and its copy of the cache file (the file itself stays): the next call of each
    shape decides again, from the file or by measuring."""
    global _disk
    with _lock:
        _memory.clear()
        _disk = None
        _spent[0] = 0.0
        _switches.clear()
        _started.clear()
        _told.clear()
