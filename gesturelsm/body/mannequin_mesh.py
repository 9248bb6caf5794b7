"""Mesh primitives for the mannequin: swept generalised cylinders, star-shaped blobs, chain skinning.

Every primitive returns a closed triangle surface with outward (counter-clockwise) faces plus, per vertex,
its "axis point" (where the girth blend shape scales from) and its coordinate along the primitive's axis
(used for skinning weights along a joint chain).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import PchipInterpolator

from ..motion.skeleton import NUM_JOINTS


@dataclass
class Part:
    """One closed surface of the mannequin."""
    name: str
    vertices: np.ndarray                 # (n, 3) float64
    faces: np.ndarray                    # (m, 3) int, local indices
    axis_points: np.ndarray              # (n, 3) centre each vertex's cross-section is scaled about
    s: np.ndarray                        # (n,) coordinate along the axis (metres from the first station)
    weights: np.ndarray | None = None    # (n, 55) skinning weights, rows sum to 1
    girth: bool = False                  # whether the girth blend shape applies
    rings: dict[str, np.ndarray] = field(default_factory=dict)  # name -> local vertex ids of a ring


def smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def profile(keys: list[tuple[float, ...]], s: np.ndarray) -> np.ndarray:
    """Monotone cubic (PCHIP) interpolation of key rows (s, v1, v2, ...) at positions s -> (len(s), k)."""
    k = np.asarray(keys, dtype=np.float64)
    return PchipInterpolator(k[:, 0], k[:, 1:], axis=0, extrapolate=True)(s)


def _superellipse(theta: np.ndarray, power: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit superellipse |x|^p + |y|^p = 1 sampled at angles theta; power (K, 1) broadcast over theta."""
    c, s = np.cos(theta), np.sin(theta)
    return np.sign(c) * np.abs(c) ** (2.0 / power), np.sign(s) * np.abs(s) ** (2.0 / power)


def sweep(name: str, centres: np.ndarray, u: np.ndarray, v: np.ndarray, radii: np.ndarray, n: int,
          power: np.ndarray | float = 2.0, cap_start: float = 0.0, cap_end: float = 0.0,
          cap_rings: int = 4, s: np.ndarray | None = None, theta: np.ndarray | None = None) -> Part:
    """Sweep a closed cross-section along K centres.

    centres (K, 3); u, v (K, 3) or (3,): the cross-section axes (unit, orthogonal to each other), ordered so
    that u x v points along the sweep direction (then faces come out counter-clockwise from outside);
    radii (K, 4) = (+u, -u, +v, -v) half-extents; power: superellipse exponent (2 = ellipse, larger =
    boxier). cap_start / cap_end: length of a rounded cap closing each end (0 = flat fan, < 0 = open end).
    theta: (n,) increasing angles of the ring vertices (default: uniform).
    """
    centres = np.asarray(centres, dtype=np.float64)
    K = len(centres)
    u = np.broadcast_to(np.asarray(u, dtype=np.float64), (K, 3))
    v = np.broadcast_to(np.asarray(v, dtype=np.float64), (K, 3))
    power = np.broadcast_to(np.asarray(power, dtype=np.float64), (K,))
    if s is None:
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(centres, axis=0), axis=1))])
    t = np.gradient(centres, axis=0)
    t /= np.linalg.norm(t, axis=1, keepdims=True)

    # rounded caps: extra stations that shrink like a quarter ellipse towards a pole
    phis = np.linspace(0.0, np.pi / 2, cap_rings + 1)[1:-1]
    stations = []                                            # (centre, scale, arc length, centre index) per ring
    if cap_start > 0:
        stations += [(centres[0] - t[0] * cap_start * np.sin(phi), np.cos(phi), s[0] - cap_start * np.sin(phi), 0)
                     for phi in phis[::-1]]
    stations += [(centres[k], 1.0, s[k], k) for k in range(K)]
    if cap_end > 0:
        stations += [(centres[-1] + t[-1] * cap_end * np.sin(phi), np.cos(phi), s[-1] + cap_end * np.sin(phi), K - 1)
                     for phi in phis]
    rows_c, rows_scale, rows_s, rows_k = zip(*stations)
    kk = np.array(rows_k)
    C = np.array(rows_c)                                     # (R, 3)
    scale = np.array(rows_scale)[:, None]                    # (R, 1)
    theta = 2 * np.pi * np.arange(n) / n if theta is None else np.asarray(theta)  # (n,)
    x, y = _superellipse(theta[None, :], power[kk][:, None])  # (R, n)
    rad = radii[kk] * scale                                  # (R, 4)
    ru = np.where(x >= 0, rad[:, :1], rad[:, 1:2]) * x       # (R, n)
    rv = np.where(y >= 0, rad[:, 2:3], rad[:, 3:4]) * y
    ring_pts = C[:, None, :] + ru[..., None] * u[kk][:, None, :] + rv[..., None] * v[kk][:, None, :]
    R = len(C)
    verts = [ring_pts.reshape(-1, 3)]
    axis_pts = [np.repeat(C, n, axis=0)]
    s_all = [np.repeat(np.array(rows_s), n)]
    faces = []
    ids = np.arange(R * n).reshape(R, n)
    for r in range(R - 1):
        a, b = ids[r], ids[r + 1]
        a1, b1 = np.roll(a, -1), np.roll(b, -1)
        faces += [np.stack([a, a1, b1], 1), np.stack([a, b1, b], 1)]
    ps = pe = -1
    if cap_start >= 0:
        start_pole = centres[0] - t[0] * cap_start
        ps = len(np.concatenate(verts))
        verts.append(start_pole[None])
        axis_pts.append(start_pole[None])
        s_all.append(np.array([s[0] - cap_start]))
        a = ids[0]
        faces.append(np.stack([np.full(n, ps), np.roll(a, -1), a], 1))
    if cap_end >= 0:
        end_pole = centres[-1] + t[-1] * cap_end
        pe = len(np.concatenate(verts))
        verts.append(end_pole[None])
        axis_pts.append(end_pole[None])
        s_all.append(np.array([s[-1] + cap_end]))
        b = ids[-1]
        faces.append(np.stack([np.full(n, pe), b, np.roll(b, -1)], 1))
    part = Part(name, np.concatenate(verts), np.concatenate(faces).astype(np.int64),
                np.concatenate(axis_pts), np.concatenate(s_all))
    first = len(phis) if cap_start > 0 else 0
    for k in range(K):  # rings at the given stations, for joint regressors
        part.rings[f"station{k}"] = ids[first + k]
    part.rings.update(start_pole=np.array([ps]), end_pole=np.array([pe]))
    part.rings["first"], part.rings["last"] = ids[0], ids[-1]
    return part


def join_rings(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Triangles of the band between two closed vertex loops of equal length (a then b along the sweep)."""
    a1, b1 = np.roll(a, -1), np.roll(b, -1)
    return np.concatenate([np.stack([a, a1, b1], 1), np.stack([a, b1, b], 1)])


def merge_parts(name: str, parts: list[Part], extra_faces: list[np.ndarray]) -> Part:
    """One part from several (vertex ids of later parts shifted); extra_faces use the merged numbering."""
    off = np.cumsum([0] + [len(p.vertices) for p in parts])
    out = Part(name, np.concatenate([p.vertices for p in parts]),
               np.concatenate([p.faces + o for p, o in zip(parts, off)] + extra_faces),
               np.concatenate([p.axis_points for p in parts]), np.concatenate([p.s for p in parts]))
    out.weights = np.concatenate([p.weights for p in parts])
    for p, o in zip(parts, off):
        out.rings.update({f"{p.name}/{k}": v + o for k, v in p.rings.items()})
    return out


def star_blob(name: str, centre: np.ndarray, radius_fn, n_lat: int, n_lon: int) -> Part:
    """A closed surface star-shaped about `centre`: r(direction) from `radius_fn(dirs (N,3)) -> (N,)`.

    Latitude from the +y pole (top) to the -y pole; longitude 0 = +z (front), increasing towards +x.
    """
    lat = np.linspace(0, np.pi, n_lat + 2)[1:-1]                # exclude poles
    lon = 2 * np.pi * np.arange(n_lon) / n_lon
    LA, LO = np.meshgrid(lat, lon, indexing="ij")               # (n_lat, n_lon)
    dirs = np.stack([np.sin(LA) * np.sin(LO), np.cos(LA), np.sin(LA) * np.cos(LO)], -1).reshape(-1, 3)
    poles = np.array([[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]])
    all_dirs = np.concatenate([dirs, poles])
    r = radius_fn(all_dirs)
    verts = centre + all_dirs * r[:, None]
    ids = np.arange(n_lat * n_lon).reshape(n_lat, n_lon)
    faces = []
    for i in range(n_lat - 1):
        a, b = ids[i], ids[i + 1]
        a1, b1 = np.roll(a, -1), np.roll(b, -1)
        faces.append(np.stack([a, b, b1], 1))
        faces.append(np.stack([a, b1, a1], 1))
    top, bot = n_lat * n_lon, n_lat * n_lon + 1
    faces.append(np.stack([np.full(n_lon, top), ids[0], np.roll(ids[0], -1)], 1))
    faces.append(np.stack([np.full(n_lon, bot), np.roll(ids[-1], -1), ids[-1]], 1))
    n = len(verts)
    part = Part(name, verts, np.concatenate(faces).astype(np.int64), np.repeat(centre[None], n, 0),
                verts[:, 1] - centre[1])
    part.rings["all"] = np.arange(n)
    return part


def ellipsoid_exit(origin: np.ndarray, dirs: np.ndarray, centre: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """Distance from origin along unit dirs (N, 3) to the far intersection with an axis-aligned ellipsoid.

    0 where the ray misses it or the ellipsoid lies behind the origin.
    """
    a = np.asarray(axes, dtype=np.float64)
    d = dirs / a
    o = (origin - centre) / a
    A = (d * d).sum(1)
    B = 2 * (d * o).sum(1)
    C = (o * o).sum() - 1.0
    disc = B * B - 4 * A * C
    t = (-B + np.sqrt(np.clip(disc, 0.0, None))) / (2 * A)
    return np.where((disc > 0) & (t > 0), t, 0.0)


def soft_max(values: list[np.ndarray], width: float) -> np.ndarray:
    """Log-sum-exp maximum: the union of shapes with creases rounded over about `width` metres."""
    v = np.stack(values) / width
    m = v.max(0)
    return width * (m + np.log(np.exp(v - m).sum(0)))


def chain_weights(s: np.ndarray, bones: list[int], cuts: list[tuple[float, float, float]]) -> np.ndarray:
    """Skinning weights (n, 55) along a chain of bones.

    bones[i] is the joint whose rotation moves segment i; cuts[i] = (s_joint, before, after): between
    segment i and i + 1 at axis position s_joint, blended smoothly from s_joint - before to s_joint + after.
    """
    n = len(s)
    W = np.zeros((n, NUM_JOINTS))
    remaining = np.ones(n)
    for i, bone in enumerate(bones):
        if i < len(cuts):
            sj, b, a = cuts[i]
            f = smoothstep((s - (sj - b)) / max(a + b, 1e-9))  # share passed on to the next bones
        else:
            f = np.zeros(n)
        W[:, bone] += remaining * (1 - f)
        remaining = remaining * f
    return W
