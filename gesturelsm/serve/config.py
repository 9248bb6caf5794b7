"""The server's own settings (the `python -m app` / `gesturelsm serve` flags and their defaults), apart from the
request flow so that the command line reads its defaults without loading torch or Gradio.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..constants import MAX_SECONDS

QUEUE_SIZE = 32                 # requests waiting beyond the ones being served; more get "Queue is full"


@dataclass(frozen=True)
class ServiceSettings:
    checkpoints: str | None = None          # folder with tokenizer/ and generator/ (default: shipped assets/)
    body_model: str | None = None           # SMPL-X .npz (default: $GESTURELSM_SMPLX_MODEL or the mannequin)
    beat2: str | None = None                # BEAT2-layout folder: ground truth for known takes
    workdir: str | None = None              # where outputs go (default: <tmp>/gesturelsm-app)
    max_seconds: float = MAX_SECONDS        # longest speech accepted
    max_upload_mb: float = 50.0             # largest upload accepted
    keep_minutes: float = 60.0              # outputs older than this are deleted
    concurrency: int = 1                    # requests generated at the same time (the rest queue)
    max_steps: int = 32                     # the page's steps slider stops here (and at the methods' max_steps)
    max_ddim_steps: int = 100               # the page's DDIM steps slider stops here
    render_nice: int = 19                   # the mp4 renders in a process of its own this much niced
                                            # (render/background.py)
    threads: int = 1                        # math threads per request and live stream (a step is fastest on 1 of 2
                                            # cores, and a browser on the same machine keeps the other)
    ahead: bool = True                      # make the motion of the page's settings before the click (serve/ahead.py)


__all__ = ["QUEUE_SIZE", "ServiceSettings"]
