"""Run the server-side render at a lower CPU priority than generation, live streams and (on one machine) the browser.

The page shows the motion in the browser first; the mp4 is rendered after it, for download and sharing. On a 2-core
machine the renderer (Mesa llvmpipe's threads and ffmpeg) took every core it could, and a browser on the same machine
drew the player at ~15 frames per second while it ran (benchmarks/player_latency.py). Linux keeps a niceness per thread,
and threads and processes started by a thread inherit it, so the render runs in its own thread niced by `nice`: the
renderer's GL threads (created with the render's context) and its ffmpeg follow. Elsewhere (no per-thread niceness,
or not allowed) it just runs in that thread.

    video = in_background(lambda: render_video(...), nice=19)     # the page's setting (app_service.ServiceSettings)
"""
from __future__ import annotations

import contextvars
import os
import threading
from typing import Callable, TypeVar

T = TypeVar("T")


def lower_this_thread(nice: int) -> bool:
    """Add `nice` to the calling thread's niceness (Linux: per thread); False where that is not possible."""
    if nice <= 0 or not hasattr(os, "setpriority"):
        return False
    tid = threading.get_native_id()
    try:
        os.setpriority(os.PRIO_PROCESS, tid, min(19, os.getpriority(os.PRIO_PROCESS, tid) + nice))
    except OSError:
        return False
    return True


def in_background(fn: Callable[[], T], nice: int = 19) -> T:
    """fn() in a new thread niced by `nice`, waited for; its result or its exception. Context variables (e.g. a web
    framework's progress reporting) are carried into the thread."""
    ctx, box = contextvars.copy_context(), {}

    def run() -> None:
        lower_this_thread(nice)
        try:
            box["value"] = ctx.run(fn)
        except BaseException as exc:  # noqa: BLE001 (re-raised in the caller's thread)
            box["error"] = exc

    t = threading.Thread(target=run, name="gesturelsm-render", daemon=True)
    t.start()
    t.join()
    if "error" in box:
        raise box["error"]
    return box["value"]
