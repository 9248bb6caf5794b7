"""The server-side render runs in its own thread at a lower CPU priority (render/background.py): the niceness is the
thread's (the caller keeps its own), results and exceptions come back, context variables are carried over."""
from __future__ import annotations

import contextvars
import os
import sys
import threading

import pytest

from gesturelsm.render.background import in_background

linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="per-thread niceness is Linux's")


def niceness() -> int:
    return os.getpriority(os.PRIO_PROCESS, threading.get_native_id())


@linux
def test_the_work_runs_niced_in_another_thread_and_the_caller_keeps_its_priority():
    before = niceness()
    seen = in_background(lambda: (threading.get_native_id(), niceness()), nice=5)
    assert seen[0] != threading.get_native_id()
    assert seen[1] == min(19, before + 5)
    assert niceness() == before


@linux
def test_children_of_the_work_inherit_its_priority():
    """The renderer's GL threads and ffmpeg are started from the render thread: they must be niced too."""
    import subprocess

    before = niceness()
    out = in_background(lambda: subprocess.run(["sh", "-c", "cut -d' ' -f19 /proc/self/stat"], capture_output=True,
                                               text=True, check=True).stdout, nice=4)
    assert int(out) == min(19, before + 4)


def test_results_errors_and_context_come_back():
    var = contextvars.ContextVar("request", default="none")
    var.set("visitor-1")
    assert in_background(var.get, nice=0) == "visitor-1"
    with pytest.raises(ValueError, match="broken"):
        in_background(lambda: (_ for _ in ()).throw(ValueError("broken")))
