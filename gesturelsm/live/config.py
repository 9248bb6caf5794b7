"""The live mode's settings (`LiveConfig`), without torch: `gesturelsm live --help` shows their defaults before any
model code loads; stream.py (the generator in streaming form) runs with them."""
from __future__ import annotations

from dataclasses import dataclass

from ..errors import InputError


@dataclass(frozen=True)
class LiveConfig:
    commit: int = 3                # c: latents finalised per window (1 latent = 4 frames = 133.3 ms)
    lookahead: int = 1             # latents of real audio past the finalised span before a window runs
    steps: int = 4                 # sampler steps per window
    cfg: float = 6.0               # guidance; offline's 2 streams calm motion (module docstring)
    seed: int = 0
    method: str = "gesturelsm"
    context_s: float = 6.0         # audio before a window that onset detection sees
    decode_context: int = 16       # final latents left of the emitted span given to the decoder
    decode_lag: int = 0            # final latents required right of the emitted span (0: provisional ones)
    blend_frames: int = 8          # frames after a chunk's end decoded now and faded into the next chunk's start
    held: int = 4                  # final latents before the new ones held fixed while sampling (0: all in the window)
    grounding: bool = True         # feet on the ground, causally, chunk by chunk (grounding/motion_stream.py)

    def check(self, t: int, s: int) -> None:
        if not 1 <= self.commit <= t - s:
            raise InputError(f"commit must be between 1 and {t - s} latents (got {self.commit})")
        if min(self.lookahead, self.decode_lag, self.decode_context, self.blend_frames, self.held) < 0:
            raise InputError("lookahead, decode_lag, decode_context, blend_frames and held must be >= 0")


__all__ = ["LiveConfig"]
