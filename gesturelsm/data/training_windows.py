"""Fixed-length windows over a sequence (frames at 30 fps)."""
from __future__ import annotations


def window_starts(num_frames: int, length: int, stride: int) -> list[int]:
    """Start frames of every full window of `length` frames, `stride` apart. Empty if too short."""
    if length <= 0 or stride <= 0:
        raise ValueError(f"window length and stride must be positive (got {length}, {stride})")
    if num_frames < length:
        return []
    return list(range(0, num_frames - length + 1, stride))
