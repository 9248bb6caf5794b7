"""Work the page does beside generation, at a lower priority: the statistics and downloads of the methods made so
far while the next method is generated.

`aside(f, *args)` runs f in one worker thread whose scheduling priority is lowered by NICE (Linux gives each thread
its own niceness; threads of one process share its scheduling group, so the generation threads, at the process's
own priority, get the cores first) and returns its result; the calling event handler only waits. Elsewhere (no
per-thread niceness) it runs at the same priority.
"""
from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Callable, TypeVar

NICE = 10
T = TypeVar("T")
_pool: ThreadPoolExecutor | None = None
_lock = threading.Lock()


def _lower() -> None:
    try:
        tid = threading.get_native_id()
        os.setpriority(os.PRIO_PROCESS, tid, min(19, os.getpriority(os.PRIO_PROCESS, tid) + NICE))
    except (AttributeError, OSError):                  # not Linux, or not allowed: the same priority
        pass


def aside(f: Callable[..., T], *args) -> T:
    """f(*args), computed in the lowered worker thread (one at a time); exceptions reach the caller."""
    global _pool
    with _lock:
        if _pool is None:
            _pool = ThreadPoolExecutor(1, thread_name_prefix="gesturelsm-aside", initializer=_lower)
    return _pool.submit(f, *args).result()
