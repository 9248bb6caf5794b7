"""Motions -> frames: input checks, the clip's camera and floor, posing in chunks, tiles, labels.

    frames = render_frames([seq], frame_indices=[0, 30])            # (2, H, W, 3) uint8
    for frame in iter_frames([a, b, c], labels=["8 steps", "RF", "GT"]): ...   # (H, 3 W, 3) each

Frame k of the output shows motion frame k (30 fps, frame 0 = time 0). Motions of different lengths in one
side-by-side are padded with their last frame (a `RenderWarning` says so).
"""
from __future__ import annotations

import warnings
from pathlib import Path
from typing import Iterator, Sequence

import numpy as np

from ..body.model import resolve_body   # noqa: F401 (re-exported: gesturelsm.render.resolve_body)
from ..errors import InputError
from ..motion.sequence import FPS, MotionSequence
from .camera import Camera
from .figure import make_figure
from .labels import LabelPatch, label_lines, make_label
from .scene import SceneRenderer
from .style import RenderStyle

MotionLike = MotionSequence | str | Path
SAMPLE_FRAMES = 120          # frames sampled to frame the camera (evenly over the clip)
SAMPLE_BYTES = 256 * 2 ** 20  # sampled vertices (float32) held to frame the camera; beyond, they are posed twice
POSE_POINTS = 2_000_000       # vertex-frames posed at once (about 70 bytes each while posing and framing)
MAX_BODIES = 8


class RenderWarning(UserWarning):
    """Something the user should know about a render (padding, trimmed audio); the render went on."""


def prepare_motions(motions: Sequence[MotionLike] | MotionLike) -> list[MotionSequence]:
    """Load paths, check frame rates, pad shorter motions with their last frame (with a warning)."""
    if isinstance(motions, (MotionSequence, str, Path)):
        motions = [motions]
    seqs = [m if isinstance(m, MotionSequence) else MotionSequence.load(m) for m in motions]
    if not seqs:
        raise InputError("nothing to render: no motions given")
    if len(seqs) > MAX_BODIES:
        raise InputError(f"{len(seqs)} motions: at most {MAX_BODIES} can be shown side by side")
    for i, s in enumerate(seqs):
        if s.num_frames == 0:
            raise InputError(f"motion {i + 1} has no frames")
        if s.fps != FPS:
            raise InputError(f"motion {i + 1} is at {s.fps} fps; rendering expects {FPS} fps (BEAT2)")
    T = max(s.num_frames for s in seqs)
    out = []
    for i, s in enumerate(seqs):
        if s.num_frames < T:
            warnings.warn(f"motion {i + 1} has {s.num_frames} frames, the longest {T}: padded with its last "
                          f"frame ({(T - s.num_frames) / FPS:.2f} s held still)", RenderWarning, stacklevel=3)
            pad = T - s.num_frames
            s = MotionSequence(np.concatenate([s.poses, np.repeat(s.poses[-1:], pad, 0)]),
                               np.concatenate([s.trans, np.repeat(s.trans[-1:], pad, 0)]),
                               np.concatenate([s.expressions, np.repeat(s.expressions[-1:], pad, 0)]), s.betas, s.fps)
        out.append(s)
    return out


def _sample_chunks(figure, max_frames: int = SAMPLE_FRAMES) -> list:
    """Per motion: its framing vertices (`figure.frame_points`) at k <= max_frames evenly spaced frames (first and
    last included), as chunks of frames (k_i, V, 3) of at most POSE_POINTS vertex-frames each (one chunk for a
    mesh of a few thousand vertices). Held as arrays while they take at most SAMPLE_BYTES; beyond, each chunk is
    posed when it is read (`_Posing`), so a large mesh is framed within that memory."""
    ids = [np.unique(np.linspace(0, s.num_frames - 1, min(s.num_frames, max_frames)).round().astype(int))
           for s in figure.seqs]
    per = max(1, POSE_POINTS // figure.framing_vertices)
    chunks = [[i[a:a + per] for a in range(0, len(i), per)] for i in ids]
    if sum(len(i) for i in ids) * figure.framing_vertices * 12 <= SAMPLE_BYTES:
        return [[figure.frame_points(k, c) for c in cs] for k, cs in enumerate(chunks)]
    return [_Posing(figure, k, cs) for k, cs in enumerate(chunks)]


class _Posing:
    """A motion's sampled frames posed chunk by chunk, each time the list is iterated (nothing is kept)."""

    def __init__(self, figure, k: int, chunks: list[np.ndarray]):
        self.figure, self.k, self.chunks = figure, k, chunks

    def __len__(self) -> int:
        return len(self.chunks)

    def __iter__(self):
        return (self.figure.frame_points(self.k, ids) for ids in self.chunks)


def clip_layout(motions: Sequence[MotionLike] | MotionLike, body=None, style: RenderStyle | None = None,
                labels: Sequence[str] | None = None, gen_seconds: Sequence[float | None] | None = None,
                size: tuple[int, int] | None = None) -> tuple[Camera, float]:
    """The clip's fixed camera (framing every body over the whole clip, below the labels) and floor height."""
    style = (style or RenderStyle()).with_size(size)
    seqs = prepare_motions(motions)
    patches = _label_patches(len(seqs), labels, gen_seconds, style)
    return _layout(make_figure(seqs, body), style, _reserve(patches, style))


def fit_camera(motions: Sequence[MotionLike] | MotionLike, body=None, style: RenderStyle | None = None,
               labels: Sequence[str] | None = None, gen_seconds: Sequence[float | None] | None = None,
               size: tuple[int, int] | None = None) -> Camera:
    """The camera `render_video` uses for these motions and labels (2D keypoints are projected through it)."""
    return clip_layout(motions, body, style, labels, gen_seconds, size)[0]


def _reserve(patches: list[LabelPatch | None], style: RenderStyle) -> float:
    """Fraction of the tile height the labels take at the top (kept free of bodies)."""
    r = max([(p.y + p.rgba.shape[0] + 2) / style.height for p in patches if p is not None], default=0.0)
    return min(r, 0.3)


def _hull(points: np.ndarray) -> np.ndarray:
    """The convex hull's vertices (what framing depends on), or all points when qhull cannot run."""
    if len(points) < 64:
        return points
    try:
        from scipy.spatial import ConvexHull

        return points[ConvexHull(points).vertices]
    except Exception:  # degenerate (flat) point sets
        return points


def _layout(figure, style: RenderStyle, reserve_top: float = 0.0) -> tuple[Camera, float]:
    """The camera framing every motion's figure over the clip, and the floor height (figure.py's figures)."""
    samples = _sample_chunks(figure)                               # per motion: chunks of (k, V, 3)
    floor_y = min(float(v[..., 1].min()) for chunks in samples for v in chunks)
    pts = []
    for k, chunks in enumerate(samples):
        hulls = [_framed(figure, k, v, style, floor_y) for v in chunks]
        pts.append(hulls[0] if len(hulls) == 1 else _hull(np.concatenate(hulls)))
    W, H = style.size
    cam = Camera.fit(np.concatenate(pts), W, H, style.yfov_deg, style.elevation_deg, style.margin,
                     reserve_top=reserve_top)
    return cam, floor_y


def _framed(figure, k: int, v: np.ndarray, style: RenderStyle, floor_y: float) -> np.ndarray:
    """The convex hull of what must stay in view of motion k's sampled vertices v (k, V, 3)."""
    p = v.reshape(-1, 3).astype(np.float64)
    if style.framing == "upper":
        p = p[p[:, 1] > figure.hips_y(k) - 0.12]
    elif style.shadow and style.floor != "none":   # keep each frame's contact shadow around the feet in view
        feet = v[:, :, [0, 2]] + np.where(v[:, :, 1:2] < floor_y + 0.05, 0.0, np.nan)
        with warnings.catch_warnings():                         # frames with no foot down: all NaN
            warnings.simplefilter("ignore", RuntimeWarning)
            lo, hi = np.nanmin(feet, 1) - 0.12, np.nanmax(feet, 1) + 0.12  # (k, 2)
        corners = [np.stack([a[:, 0], np.full(len(a), floor_y), b[:, 1]], 1)
                   for a in (lo, hi) for b in (lo, hi)]
        p = np.concatenate([p] + [c[np.isfinite(c).all(1)] for c in corners])
    return _hull(p)


def _label_patches(n: int, labels: Sequence[str] | None, gen_seconds: Sequence[float | None] | None,
                   style: RenderStyle) -> list[LabelPatch | None]:
    if labels is not None and len(labels) != n:
        raise InputError(f"{len(labels)} labels for {n} motions: give one label per motion")
    if gen_seconds is not None and len(gen_seconds) != n:
        raise InputError(f"{len(gen_seconds)} generation times for {n} motions: give one per motion")
    if labels is None and gen_seconds is None:
        return [None] * n
    px = style.label_px or max(10, round(style.height / 30))
    dark = float(np.mean(style.background)) < 0.45
    return [make_label(label_lines(labels[i] if labels else None, gen_seconds[i] if gen_seconds else None),
                       style.width, px, dark) for i in range(n)]


def compose(tiles: list[np.ndarray], patches: list[LabelPatch | None], style: RenderStyle) -> np.ndarray:
    """Tiles side by side (a 1-pixel divider between them), labels blended in."""
    frame = tiles[0] if len(tiles) == 1 else np.concatenate(tiles, axis=1)
    frame = np.ascontiguousarray(frame)
    W = style.width
    if len(tiles) > 1:
        div = np.asarray(style.background) * 0.82 * 255
        for i in range(1, len(tiles)):
            frame[:, i * W] = div.astype(np.uint8)
    for i, p in enumerate(patches):
        if p is not None:
            p.blend_into(frame, i * W)
    return frame


def iter_frames(motions: Sequence[MotionLike] | MotionLike, *, body=None, style: RenderStyle | None = None,
                size: tuple[int, int] | None = None, labels: Sequence[str] | None = None,
                gen_seconds: Sequence[float | None] | None = None, camera: Camera | None = None,
                frame_indices: Sequence[int] | None = None, chunk: int = 32,
                character=None, grounding: bool = True) -> Iterator[np.ndarray]:
    """Yield (H, N * W, 3) uint8 frames, one per motion frame (or per index in `frame_indices`).
    character: a retarget.Character whose own mesh is drawn instead of the body (None: the body; a skeleton
    without a mesh: the body, with a RenderWarning), its feet planted on its own legs unless `grounding` is off."""
    style = (style or RenderStyle()).with_size(size)
    seqs = prepare_motions(motions)
    figure = make_figure(seqs, body, character, grounding)
    for note in figure.notes:
        warnings.warn(note, RenderWarning, stacklevel=2)
    patches = _label_patches(len(seqs), labels, gen_seconds, style)
    cam, floor_y = _layout(figure, style, _reserve(patches, style))
    if camera is not None:
        cam = camera if (camera.width, camera.height) == style.size else camera.resized(*style.size)
    T = seqs[0].num_frames
    idx = np.arange(T) if frame_indices is None else np.asarray(frame_indices, np.int64).reshape(-1)
    if idx.size and (idx.min() < 0 or idx.max() >= T):
        raise InputError(f"frame indices must be in 0..{T - 1}")
    with SceneRenderer(figure.faces, figure.num_vertices, len(seqs), cam, style, floor_y, figure.rest_vertices(),
                       figure.surfaces) as renderer:
        chunk = max(1, min(chunk, POSE_POINTS // (figure.num_vertices * len(seqs))))    # a large mesh: fewer frames
        for s in range(0, len(idx), chunk):
            ids = idx[s:s + chunk]
            outs = [figure.pose(k, ids) for k in range(len(seqs))]
            for k in range(len(ids)):
                normals = None if outs[0].normals is None else [o.normals[k] for o in outs]
                tiles = renderer.render([o.vertices[k] for o in outs], [o.root_xz[k] for o in outs], normals)
                yield compose(tiles, patches, style)


def render_frames(motions: Sequence[MotionLike] | MotionLike, frame_indices: Sequence[int] | None = None, *,
                  body=None, style: RenderStyle | None = None, size: tuple[int, int] | None = None,
                  labels: Sequence[str] | None = None, gen_seconds: Sequence[float | None] | None = None,
                  camera: Camera | None = None, character=None, grounding: bool = True) -> np.ndarray:
    """(K, H, N * W, 3) uint8: the frames at `frame_indices` (all frames when None)."""
    frames = list(iter_frames(motions, body=body, style=style, size=size, labels=labels, gen_seconds=gen_seconds,
                              camera=camera, frame_indices=frame_indices, character=character, grounding=grounding))
    if not frames:
        st = (style or RenderStyle()).with_size(size)
        return np.zeros((0, st.height, st.width, 3), np.uint8)
    return np.stack(frames)
