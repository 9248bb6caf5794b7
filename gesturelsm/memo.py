"""A memo of an expensive function's last results by key, shared by threads: `Recent`.

    answers = Recent(8)                      # keeps the last 8
    value = answers.get(key, compute)        # computed once per key; concurrent callers of a key wait for it
    answers.forget(key)

Used for the words recognised from an upload's samples (asr/source.py) and for an upload's decoded and prepared
speech (serve/prepared.py).
"""
from __future__ import annotations

import threading
from collections import OrderedDict
from typing import Callable, Generic, Hashable, TypeVar

V = TypeVar("V")


class Recent(Generic[V]):
    """The last `size` results of an expensive function by key; concurrent callers of one key compute it once (the
    others wait for it; if it raises, each computes for itself). Thread-safe."""

    def __init__(self, size: int = 8):
        self.size = size
        self._lock = threading.Lock()
        self._done: OrderedDict[Hashable, V] = OrderedDict()
        self._running: dict[Hashable, threading.Event] = {}

    def get(self, key: Hashable, compute: Callable[[], V]) -> V:
        while True:
            with self._lock:
                if key in self._done:
                    self._done.move_to_end(key)
                    return self._done[key]
                busy = self._running.get(key)
                if busy is None:
                    self._running[key] = threading.Event()
                    break
            busy.wait()
            with self._lock:
                if key in self._done:
                    continue
            return compute()                                     # the first caller failed: try for ourselves
        try:
            value = compute()
            with self._lock:
                self._done[key] = value
                while len(self._done) > self.size:
                    self._done.popitem(last=False)
            return value
        finally:
            with self._lock:
                self._running.pop(key).set()

    def forget(self, key: Hashable) -> None:
        """Drop the result of `key` (the next `get` computes it again)."""
        with self._lock:
            self._done.pop(key, None)

    def __len__(self) -> int:
        return len(self._done)

    def clear(self) -> None:
        with self._lock:
            self._done.clear()
