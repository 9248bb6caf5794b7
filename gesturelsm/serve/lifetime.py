"""How long files live on the server: `--keep-minutes` for the app's outputs and for Gradio's own copies.

- The service's request folders (`<workdir>/req-<128 random bits>`) are swept by a timer thread every
  `sweep_seconds(keep_minutes)` (a quarter of the lifetime, between 5 s and 60 s), not only when the next
  request starts, and all of them are deleted when the server stops.
- Gradio's cache (uploads and the copies of outputs it serves) gets `delete_cache=(frequency, age)` with
  the same age and frequency; Gradio also empties it when the server stops.

So a file is gone at most keep_minutes + sweep_seconds after it was written.
"""
from __future__ import annotations

import atexit
import logging
import threading
from typing import Callable

log = logging.getLogger("gesturelsm.app")


def sweep_seconds(keep_minutes: float) -> float:
    """How often expired files are looked for: a quarter of their lifetime, clamped to 5-60 s."""
    return float(min(60.0, max(5.0, keep_minutes * 60.0 / 4)))


def gradio_delete_cache(keep_minutes: float) -> tuple[int, int]:
    """Blocks(delete_cache=(frequency, age)) in whole seconds for `keep_minutes`."""
    return max(1, int(sweep_seconds(keep_minutes))), max(1, int(round(keep_minutes * 60.0)))


class Sweeper:
    """Calls `sweep()` every `interval_s` seconds on a daemon thread; `stop()` ends the thread and calls
    `final()` once (also at interpreter exit)."""

    def __init__(self, sweep: Callable[[], int], interval_s: float, final: Callable[[], int] | None = None):
        self.sweep, self.interval_s, self.final = sweep, float(interval_s), final
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="gesturelsm-sweeper", daemon=True)
        self._stopped = False

    def start(self) -> "Sweeper":
        self._thread.start()
        atexit.register(self.stop)
        return self

    def _loop(self) -> None:
        while not self._stop.wait(self.interval_s):
            try:
                removed = self.sweep()
                if removed:
                    log.info("deleted %d expired output folder(s)", removed)
            except Exception:  # a sweep must never kill the thread; the next one retries
                log.exception("sweeping expired outputs failed")

    def stop(self) -> None:
        if self._stopped:
            return
        self._stopped = True
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5)
        atexit.unregister(self.stop)
        if self.final is not None:
            removed = self.final()
            log.info("shutdown: deleted %d output folder(s)", removed)
