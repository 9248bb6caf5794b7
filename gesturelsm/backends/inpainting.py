"""Edits in latent space, the part every backend that can edit shares.

A backend encodes the input motion with its tokenizers (the continuous encoder output before quantisation, as its
generator was trained on) and holds those latents while it samples (`held_latents`): every latent of a region not
edited, and of an edited region outside its ranges. A keyframe's latent is the encoding of its pose held still
(`static_clip`), held in the regions it pins at the keyframe's latent and, in part, at the `KEY_REACH` latents on
each side (weights 0.5 (1 + cos(pi d / (KEY_REACH + 1))) at d latents away: flows/base.py `hold` mixes them in at
every step), so the sampled motion turns into the pose and out of it over about half a second instead of flicking
to it in one latent (a latent held alone is ignored by its sampled neighbours: the motion reached the pose for
4 frames and left it at up to 12 rad/s on the shipped model; with 4 latents of reach it came within 2.1 degrees
per joint, moving at 2.1-4.3 rad/s: docs/EDITING.md). Only the frames near the regenerated latents are decoded
(`decoded_span`): the pipeline keeps the input's own frames everywhere else (motion/merge.py).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import torch

from ..flows import Held
from ..motion.editing import LATENT_FRAMES, EditSpec, Keyframe
from ..motion.sequence import MotionSequence

DECODE_CONTEXT = 16          # latents decoded on each side of the regenerated ones (the decoders' reach, cropped)
STATIC_FRAMES = 128          # frames of a held pose encoded for a keyframe; its middle latent is used
KEY_REACH = 4                # latents on each side of a keyframe's that are held towards its pose, in part


@dataclass
class EditOutput:
    """What a backend's edit returns: its decoded motion over frames [start, start + motion.num_frames)."""
    motion: MotionSequence
    start: int
    timings: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


def held_latents(spec: EditSpec, regions: tuple[str, ...], known: torch.Tensor,
                 pose_latent: Callable[[Keyframe, str], torch.Tensor]) -> Held:
    """The latents to hold for `spec`: `known` (R, L, D), the input's latents of `regions` in order, known wherever
    a region is kept; keyframes' pose latents (`pose_latent(key, region)` -> (D,)) held, in part, around theirs
    (module docstring; the mask is then a float weight)."""
    R, L, _ = known.shape
    mask = torch.ones(R, L, 1, dtype=torch.bool)
    for r, name in enumerate(regions):
        if name in spec.ranges:
            mask[r, :, 0] = ~torch.from_numpy(spec.free_latents(name, L))
    if not spec.keyframes:
        return Held(known, mask)
    known, weight = known.clone(), mask.float()
    d = torch.arange(-KEY_REACH, KEY_REACH + 1)
    bump = 0.5 * (1 + torch.cos(torch.pi * d / (KEY_REACH + 1)))
    for key in spec.keyframes:
        at = min(key.frame // LATENT_FRAMES, L - 1)
        lats, w = at + d, bump
        inside = (lats >= 0) & (lats < L)
        lats, w = lats[inside], w[inside]
        for name in spec.pinned(key):
            r = regions.index(name)
            stronger = w > weight[r, lats, 0]
            known[r, lats[stronger]] = pose_latent(key, name)
            weight[r, lats[stronger], 0] = w[stronger]
    return Held(known, weight)


def decoded_span(spec: EditSpec, num_latents: int, context: int = DECODE_CONTEXT) -> tuple[int, int]:
    """[lo, hi) latents to decode: the regenerated ones of every edited region with `context` latents each side."""
    free = np.zeros(num_latents, bool)
    for name in spec.regions:
        free |= spec.free_latents(name, num_latents)
    idx = np.flatnonzero(free)
    return max(0, int(idx[0]) - context), min(num_latents, int(idx[-1]) + 1 + context)


def static_clip(pose: np.ndarray, frames: int = STATIC_FRAMES) -> MotionSequence:
    """`pose` (165,) held still for `frames` frames, standing at the origin."""
    return MotionSequence(np.repeat(np.asarray(pose, np.float32).reshape(1, -1), frames, 0),
                          np.zeros((frames, 3), np.float32), np.zeros((frames, 100), np.float32))


def middle_latent(z: torch.Tensor) -> torch.Tensor:
    """(1, n, D) latents of a static clip -> (D,) the middle one (farthest from the clip's padded ends)."""
    return z[0, z.shape[1] // 2]


__all__ = ["DECODE_CONTEXT", "EditOutput", "KEY_REACH", "STATIC_FRAMES", "decoded_span", "held_latents",
           "middle_latent",
           "static_clip"]
