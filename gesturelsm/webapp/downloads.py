"""The page's downloads list (`#downloads`), filled by two events that can finish in either order.

While a request's methods are generated, `made_so_far` lists the npz + BVH of each method made (beside
generation, in the lowered `aside` thread); once the motion is whole, `completing` writes every download (GLB,
keypoints, ARKit face, the character's files) and lists them. The first event is triggered by the player's payload
and waits behind the statistics, so it may run after the second with a state that has no downloads yet: it must
never put the shorter list back. Each request (its job folder) has one lock; `completing` records its list under it,
and `made_so_far` answers with that list once it exists.
"""
from __future__ import annotations

import threading
from collections import OrderedDict
from pathlib import Path
from contextlib import contextmanager
from typing import Callable, Iterator

KEEP = 256          # requests remembered (the newest); an older request's late event is answered with its npz + BVH


class Downloads:
    def __init__(self):
        self._done: OrderedDict[Path, list[str]] = OrderedDict()
        self._locks: OrderedDict[Path, threading.Lock] = OrderedDict()
        self._guard = threading.Lock()

    def _lock(self, folder: Path) -> threading.Lock:
        with self._guard:
            lock = self._locks.setdefault(folder, threading.Lock())
            self._locks.move_to_end(folder)
            while len(self._locks) > KEEP:
                self._locks.popitem(last=False)
            return lock

    def made_so_far(self, folder: Path, each: Callable[[], list[Path]]) -> list[str]:
        """The whole list when `completing` ran for this request, else `each()` (npz + BVH of the methods made)."""
        with self._lock(folder):
            done = self._done.get(folder)
            return list(done) if done is not None else [str(p) for p in each()]

    @contextmanager
    def completing(self, folder: Path) -> Iterator[Callable[[list[str]], None]]:
        """`with downloads.completing(folder) as remember: ...; remember(files)`: every download written under the
        request's lock and remembered, so a late `made_so_far` gives the same list."""
        with self._lock(folder):
            yield lambda files: self._remember(folder, files)

    def _remember(self, folder: Path, files: list[str]) -> None:
        with self._guard:
            self._done[folder] = list(files)
            while len(self._done) > KEEP:
                self._done.popitem(last=False)
