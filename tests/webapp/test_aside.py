"""The page's side work (statistics and downloads while the next method is generated) runs in a thread of lower
priority (gesturelsm/webapp/aside.py), returns its result to the caller and raises its errors there."""
from __future__ import annotations

import os
import sys
import threading

import pytest

from gesturelsm.webapp.aside import NICE, aside


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="per-thread niceness as Linux has it")
def test_side_work_runs_niced_and_returns_or_raises():
    def niceness() -> tuple[int, int]:
        return threading.get_native_id(), os.getpriority(os.PRIO_PROCESS, threading.get_native_id())

    mine = os.getpriority(os.PRIO_PROCESS, threading.get_native_id())
    tid, nice = aside(niceness)
    assert tid != threading.get_native_id() and nice == min(19, mine + NICE)
    assert aside(niceness)[0] == tid                                  # one worker, reused
    assert mine == os.getpriority(os.PRIO_PROCESS, threading.get_native_id())     # the caller keeps its own

    def fails():
        raise ValueError("side work failed")
    with pytest.raises(ValueError, match="side work failed"):
        aside(fails)
