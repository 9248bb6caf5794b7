"""Conventions shared by the whole package, defined once: speech is 16 kHz mono, motion is 30 frames per second,
progress is reported as (fraction, message), the longest speech accepted; and where the shipped checkpoints and body
model live."""
from pathlib import Path
from typing import Callable

SAMPLE_RATE = 16_000        # Hz: every audio array inside the package
FPS = 30                    # motion frames per second (BEAT2's rate)
Progress = Callable[[float, str], None]     # progress callbacks: (fraction done 0-1, what is being done)
# Longest speech accepted by every entry point unless configured (the server's --max-seconds, the pipeline's
# max_seconds, the commands' --max-seconds). The work of one request grows with its length (transcription, each
# method's sampling, a video of every frame): 5 minutes bounds what one visitor holds on a shared server and still
# covers a long answer or monologue; the commands and Python take the same limit and raise it when asked.
MAX_SECONDS = 300.0
# Longest motion any part of the package reads or makes (motion/motion_file.py refuses longer files from their
# headers, before reading their data; `generate --max-seconds` and the server's limit cannot be raised past it):
# one hour, 108,000 frames at 30 fps, about 120 MB of float32 poses, translation and expressions.
MAX_MOTION_SECONDS = 3600.0
# The smoothing of finished motion (motion/postprocess.py), here so that the settings need no torch to name them.
SMOOTHING_WINDOWS = {"off": 0, "light": 5, "medium": 9, "strong": 15}     # frames at 30 fps
# The default of the app, `gesturelsm generate` and the study batch. "light" because the tokenizers' decoders still
# add some frame-to-frame jitter the speaker does not have (the real held-out motion's round trip: jerk 27 -> 36
# m/s^3); on the shipped GestureLSM (8 steps, held-out speech) it takes jerk from 34 to 27 (the speaker: 30) and
# leaves the raised share, wrist height and speed unchanged (assets/MODEL_CARD.md). "off" gives the raw decoder output.
DEFAULT_SMOOTHING = "light"


def _shipped_assets() -> Path:
    """The shipped files (tokenizer/, generator/, body/, MODEL_CARD.md): inside an installed wheel they are the
    package's `_assets/` (setup.py maps the repository's top-level assets/ there); in a checkout or an editable
    install they are the repository's `assets/` beside the package."""
    package = Path(__file__).resolve().parent
    installed = package / "_assets"
    return installed if installed.is_dir() else package.parent / "assets"


ASSETS = _shipped_assets()
