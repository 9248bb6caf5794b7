"""What an edit asks for, checked once: body regions to regenerate over time ranges, and poses pinned at times.

Times are seconds of the motion (frame f is at f / 30 s). A range (a, b) of a region regenerates its frames
[round(30 a), round(30 b)); ranges of one region that overlap or touch are merged. Outside its ranges, and in every
region not edited, the motion is the input's; inside, it crosses over from the input's at each end of a range
(motion/merge.py says how long the crossing takes).

The generator works on latents of 4 frames (the tokenizers' x4 downsampling): latent l covers frames [4l, 4l + 4).
The latents sampled for a range are those with a frame within one latent of it (`EditSpec.free_latents`): where
sampled latents meet held ones the decoded motion can change fast, and that seam then falls outside the range.

A keyframe pins a pose (55 SMPL-X joints, axis-angle) at a time well inside a regenerated range of the upper body
(`KEY_SPACING` frames or more from its ends, and from other keyframes: the span over which the body turns into and
out of the pose): the upper body, and the hands where they are regenerated there too, pass through it; the legs
and face are not pinned (the pose's stance need not fit the kept legs).
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Mapping, Sequence

import numpy as np

from ..constants import FPS, SAMPLE_RATE
from ..errors import InputError, MotionFileError
from .regions import GENERATED_REGIONS
from .sequence import MotionSequence
from .skeleton import NUM_JOINTS

EDIT_LENGTH_SLACK = 1.0            # seconds the speech of an edit may differ from the motion (cut or padded)
KEY_REGIONS = ("upper", "hands")   # the regions a keyframe pins, where they are regenerated
KEY_SPACING = 12                   # frames (0.4 s): how far apart keyframes must be, the half-width of each one's pin
LATENT_FRAMES = 4                  # frames per generator latent


class EditError(InputError):
    """An edit that cannot be made as asked (regions, ranges, keyframes); the message says what to change."""


@dataclass(frozen=True)
class Keyframe:
    time: float                    # seconds into the motion
    pose: np.ndarray               # (165,) axis-angle of the 55 SMPL-X joints
    source: str = "pose"           # where the pose came from, for messages

    @property
    def frame(self) -> int:
        return int(round(self.time * FPS))


@dataclass(frozen=True)
class EditSpec:
    """A checked edit of a motion of `num_frames` frames (make one with `edit_spec`)."""
    num_frames: int
    ranges: Mapping[str, tuple[tuple[float, float], ...]]      # region -> sorted, merged ranges in seconds
    keyframes: tuple[Keyframe, ...] = field(default=())

    @property
    def regions(self) -> tuple[str, ...]:
        """The edited regions, in the regions table's order."""
        return tuple(r for r in GENERATED_REGIONS if r in self.ranges)

    def frames(self, region: str) -> np.ndarray:
        """(T,) bool: the frames of `region` that are regenerated."""
        out = np.zeros(self.num_frames, bool)
        for a, b in self.ranges.get(region, ()):
            out[_frame(a):_frame(b)] = True
        return out

    def free_latents(self, region: str, num_latents: int) -> np.ndarray:
        """(L,) bool: the latents of `region` that are sampled: those with a frame within LATENT_FRAMES of a range
        (one latent of slack each side, so the seam where sampled latents meet held ones decodes outside the
        range, where the input's frames are kept)."""
        f = np.zeros(num_latents * LATENT_FRAMES, bool)
        for a, b in self.ranges.get(region, ()):
            f[max(0, _frame(a) - LATENT_FRAMES):_frame(b) + LATENT_FRAMES] = True
        return np.asarray(f.reshape(num_latents, LATENT_FRAMES).any(1))

    def pinned(self, key: Keyframe) -> tuple[str, ...]:
        """The regions `key` pins: those of KEY_REGIONS regenerated at its frame."""
        return tuple(r for r in KEY_REGIONS if self.frames(r)[min(key.frame, self.num_frames - 1)])


    def describe(self) -> str:
        """e.g. 'upper, hands 3.00-6.00 s; face 10.00-12.00 s; 1 keyframe'."""
        by: dict[tuple, list[str]] = {}
        for r in self.regions:
            by.setdefault(self.ranges[r], []).append(r)
        parts = [", ".join(rs) + " " + ", ".join(f"{a:.2f}-{b:.2f} s" for a, b in rr) for rr, rs in by.items()]
        if self.keyframes:
            parts.append(f"{len(self.keyframes)} keyframe{'s' * (len(self.keyframes) > 1)}")
        return "; ".join(parts)


def _frame(t: float) -> int:
    return int(round(t * FPS))


def _checked_ranges(region: str, ranges: Iterable, duration: float) -> tuple[tuple[float, float], ...]:
    out = []
    for r in ranges:
        try:
            a, b = (float(v) for v in r)
        except (TypeError, ValueError):
            raise EditError(f"the range {r!r} of {region} is not a (start, end) pair of seconds") from None
        if not (np.isfinite(a) and np.isfinite(b)):
            raise EditError(f"the range {a:g}-{b:g} s of {region} is not a number of seconds")
        if b < a:
            raise EditError(f"the range {a:g}-{b:g} s of {region} is reversed: the end must come after the start")
        # in seconds first: a time like 1e308 s is outside the speech, and is never turned into a frame number
        if a < 0 or b * FPS > round(duration * FPS) + 0.5:
            raise EditError(f"the range {a:g}-{b:g} s of {region} lies outside the speech (0-{duration:.2f} s)")
        if _frame(b) <= _frame(a):
            raise EditError(f"the range {a:g}-{b:g} s of {region} is empty: give a range of at least one frame "
                            f"({1 / FPS:.3f} s)")
        out.append((a, b))
    merged: list[tuple[float, float]] = []
    for a, b in sorted(out):
        if merged and a <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(b, merged[-1][1]))
        else:
            merged.append((a, b))
    return tuple(merged)


def edit_spec(regenerate: Mapping[str, Sequence], num_frames: int, keyframes: Sequence[Keyframe] = (),
              regions: Sequence[str] = GENERATED_REGIONS, method: str = "this method") -> EditSpec:
    """The edit of a `num_frames` motion that regenerates each region of `regenerate` ({region: [(start_s,
    end_s), ...]}) and pins `keyframes`; `regions`: those the method generates. Anything that cannot be done is
    an EditError saying what to change."""
    duration = num_frames / FPS
    ranges: dict[str, tuple] = {}
    for region, rr in regenerate.items():
        if region not in GENERATED_REGIONS:
            raise EditError(f"unknown region {region!r}; the regions are {', '.join(GENERATED_REGIONS)}")
        if region not in regions:
            raise EditError(f"{method} does not generate the {region} region; it can regenerate "
                            f"{', '.join(regions)}")
        if isinstance(rr, tuple) and len(rr) == 2 and not isinstance(rr[0], (tuple, list)):
            rr = [rr]                                          # one (start, end) pair given bare
        checked = _checked_ranges(region, rr, duration)
        if checked:
            ranges[region] = checked
    if not ranges:
        raise EditError("nothing to regenerate: give at least one region and time range, e.g. upper over 3-6 s")
    spec = EditSpec(num_frames, ranges)
    return EditSpec(num_frames, ranges, _checked_keys(spec, keyframes, duration))


def _checked_keys(spec: EditSpec, keyframes: Sequence[Keyframe], duration: float) -> tuple[Keyframe, ...]:
    keys = tuple(sorted(keyframes, key=lambda k: k.time))
    for k in keys:
        if not np.isfinite(k.time) or not 0 <= k.time <= duration:
            raise EditError(f"the keyframe at {k.time:g} s lies outside the speech (0-{duration:.2f} s)")
        near = spec.frames("upper")[max(0, k.frame - KEY_SPACING):k.frame + KEY_SPACING + 1]
        if len(near) < 2 * KEY_SPACING + 1 or not near.all():
            raise EditError(f"the keyframe at {k.time:g} s needs the upper body regenerated from "
                            f"{KEY_SPACING / FPS:.1f} s before it to {KEY_SPACING / FPS:.1f} s after it (e.g. upper "
                            f"{max(0.0, k.time - 1):.1f}-{min(duration, k.time + 1):.1f} s)")
    for a, b in zip(keys, keys[1:]):
        if b.frame - a.frame < KEY_SPACING:
            raise EditError(f"the keyframes at {a.time:g} s and {b.time:g} s are closer than "
                            f"{KEY_SPACING / FPS:.1f} s; keep them at least that far apart")
    return keys


def fit_speech(samples: np.ndarray, num_frames: int) -> tuple[np.ndarray, list[str]]:
    """`samples` (mono, SAMPLE_RATE) cut or padded with silence to exactly `num_frames` frames of motion, when they
    differ by up to EDIT_LENGTH_SLACK seconds (a warning says so); further apart, an EditError."""
    n = int(np.ceil(num_frames * SAMPLE_RATE / FPS))
    gap = (len(samples) - n) / SAMPLE_RATE
    if abs(gap) > EDIT_LENGTH_SLACK:
        raise EditError(length_mismatch(num_frames, len(samples) / SAMPLE_RATE))
    warnings = []
    if abs(gap) >= 1 / FPS:
        warnings.append(f"the speech is {abs(gap):.2f} s {'longer' if gap > 0 else 'shorter'} than the motion: "
                        f"{'its end is left out' if gap > 0 else 'silence is added at its end'}")
    return np.pad(samples[:n], (0, max(0, n - len(samples)))), warnings


def length_mismatch(num_frames: int, speech_seconds: float) -> str:
    return (f"the motion is {num_frames / FPS:.2f} s long but the speech {speech_seconds:.2f} s: give the speech the "
            f"motion was made from (they may differ by up to {EDIT_LENGTH_SLACK:g} s)")


def keyframe(time: float, source, current: MotionSequence | None = None) -> Keyframe:
    """A keyframe at `time` s from a pose source: a (165,) or (55, 3) axis-angle array; (motion, frame) with a
    MotionSequence; "file.npz:FRAME" (a BEAT2-layout motion file and a frame of it, from 0); or a bare frame
    number of `current` (the motion being edited). A source that is not a pose is an EditError."""
    if isinstance(source, (int, np.integer)) and not isinstance(source, bool):
        if current is None:
            raise EditError("a keyframe given as a frame number needs the motion it is a frame of")
        source = (current, int(source))
    if isinstance(source, (str, Path)):
        return Keyframe(float(time), *_pose_from_file(str(source)))
    if isinstance(source, tuple) and len(source) == 2 and isinstance(source[0], MotionSequence):
        motion, f = source
        return Keyframe(float(time), _frame_of(motion, f, "the motion"), f"frame {f}")
    pose = np.asarray(source, np.float32)
    if pose.size != NUM_JOINTS * 3 or not np.isfinite(pose).all():
        raise EditError(f"a keyframe pose must be {NUM_JOINTS} joints x 3 axis-angle values "
                        f"(got an array of shape {pose.shape})")
    return Keyframe(float(time), pose.reshape(-1))


def _frame_of(motion: MotionSequence, f, name: str) -> np.ndarray:
    if not isinstance(f, (int, np.integer)) or not 0 <= f < motion.num_frames:
        raise EditError(f"keyframe pose: {name} has frames 0-{motion.num_frames - 1}; frame {f} is not one of them")
    return motion.poses[int(f)].copy()


def _pose_from_file(text: str) -> tuple[np.ndarray, str]:
    path, sep, frame = text.rpartition(":")
    if not sep or not re.fullmatch(r"\s*-?[0-9]+\s*", frame):       # ASCII digits (str.isdigit takes "²", "٣")
        raise EditError(f"keyframe pose {text!r}: give a motion file and a frame number as FILE.npz:FRAME")
    try:
        motion = MotionSequence.load(path)
    except MotionFileError as exc:
        raise EditError(f"keyframe pose: {exc}") from None
    return _frame_of(motion, int(frame), Path(path).name), f"{Path(path).name}:{int(frame)}"


__all__ = ["EDIT_LENGTH_SLACK", "EditError", "EditSpec", "KEY_REGIONS", "KEY_SPACING", "Keyframe", "LATENT_FRAMES",
           "edit_spec", "fit_speech", "keyframe", "length_mismatch"]
