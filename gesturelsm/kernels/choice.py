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

GESTURELSM_KERNELS forces the choice instead (nothing is measured or read from disk): `all` takes every path
where it is available, `none` none, a comma list (`linear,trace`) those named. Tests set it, so they do not
depend on the machine's timings. GESTURELSM_ONEDNN=0 turns every fast module off, whatever GESTURELSM_KERNELS says
(ops.fast_path).
"""
from __future__ import annotations

import math
import os
import statistics
import threading
import time
import warnings
from dataclasses import dataclass
from functools import lru_cache
from typing import Callable, Hashable

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
MIN_ROUND_S = 2e-4   # a round repeats a short call until it lasts about this long (timer and call overhead)

Pair = Callable[[], tuple[Callable[[], object], Callable[[], object]]]


@dataclass(frozen=True)
class Choice:
    """One decision: `path` for calls described by `key`, taken or not; `ratio` = default time / fast time;
    `source` is "measured", "cache" (read from disk) or "failed" (a side raised: the default, not stored); `cost`:
    wall seconds spent measuring it (nested choices made during its warm-up included)."""
    path: str
    key: str
    taken: bool
    ratio: float
    source: str
    cost: float = 0.0


_lock = threading.RLock()
_memory: dict[tuple[int, str, Hashable], Choice] = {}
_disk: dict[str, dict[str, dict]] | None = None         # the cache file's sections, read once per process
_spent = [0.0]                                          # wall seconds spent measuring in this process
_depth = [0]                                            # measurements in progress (nested ones run in warm-ups)


def clock() -> float:
    """This thread's CPU time at one math thread, else wall time (seconds)."""
    return time.thread_time() if torch.get_num_threads() == 1 else time.perf_counter()


def compare(default: Callable[[], object], fast: Callable[[], object],
            repeats: int = REPEATS) -> tuple[float, float]:
    """Median seconds per call of default() and fast(), after one warm-up call each (first touches, lazy
    weights, nested choices). Rounds alternate which side goes first, so drift hits both alike."""
    t0 = clock()
    default()
    once = clock() - t0
    fast()
    n = max(1, min(64, math.ceil(MIN_ROUND_S / max(once, 1e-7))))
    times: dict[int, list[float]] = {0: [], 1: []}
    for r in range(repeats):
        for side in ((0, 1) if r % 2 == 0 else (1, 0)):
            fn = fast if side else default
            start = clock()
            for _ in range(n):
                fn()
            times[side].append((clock() - start) / n)
    return statistics.median(times[0]), statistics.median(times[1])


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


def taken(path: str, key: Hashable, pair: Pair) -> bool:
    """Whether calls of `path` described by `key` (shapes) take the fast path. `pair()` gives (default, fast),
    two calls on real tensors of those shapes that compute the same thing; it is called only when the choice
    has to be measured. Not measured while tracing (the default is used and nothing is recorded)."""
    force = forced()
    if force is not None:
        return path in force
    threads = torch.get_num_threads()
    got = _memory.get((threads, path, key))
    if got is not None:
        return got.taken
    if torch.jit.is_tracing():
        return False
    with _lock:
        got = _memory.get((threads, path, key)) or _decide(threads, path, key, pair)
    return got.taken


def _decide(threads: int, path: str, key: Hashable, pair: Pair) -> Choice:
    global _disk
    machine, text = cache.machine_key(threads), key_text(path, key)
    if _disk is None:
        _disk = cache.read(cache.cache_path())
    stored = _disk.get(machine, {}).get(text)
    if stored is not None:
        choice = Choice(path, text, stored["taken"], float(stored["ratio"]), "cache")
    else:
        choice = _measure(path, text, pair)
        if choice.source == "measured":
            entry = {"taken": choice.taken, "ratio": round(choice.ratio, 4)}
            _disk.setdefault(machine, {})[text] = entry
            cache.write(cache.cache_path(), machine, {text: entry})
    _memory[(threads, path, key)] = choice
    return choice


def _measure(path: str, text: str, pair: Pair) -> Choice:
    """Time both sides; a side that fails (a private op refusing an unusual input) means: the default, for this
    process only ("failed" is not stored)."""
    start = time.perf_counter()
    _depth[0] += 1
    try:
        t_default, t_fast = compare(*pair())
    except Exception:  # the default path is always a correct answer
        return Choice(path, text, False, math.nan, "failed", time.perf_counter() - start)
    finally:
        _depth[0] -= 1
        if _depth[0] == 0:
            _spent[0] += time.perf_counter() - start
    ratio = t_default / max(t_fast, 1e-12)
    return Choice(path, text, ratio >= MARGIN, ratio, "measured", time.perf_counter() - start)


def choices() -> list[Choice]:
    """Every choice this process has made or read, in the order made."""
    return list(_memory.values())


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
