"""The mannequin's head: a smooth union of ellipsoids (cranium, face, chin, nose, lips, brow, ears) with
eye sockets, two eyeballs, a jaw region skinned to the `jaw` joint, simple expression blend shapes and the
51 FLAME-style facial landmarks. Positions are metres relative to the head joint (skull base).
"""
from __future__ import annotations

import numpy as np

from ..motion.skeleton import JOINT_INDEX as JI
from .mannequin_mesh import Part, ellipsoid_exit, smoothstep, soft_max, star_blob
from .mannequin_skeleton import EYE, RestSkeleton

BLOB_CENTRE = np.array([0.0, 0.075, 0.020])
# (centre, semi-axes) relative to the head joint; ears are mirrored
HEAD_ELLIPSOIDS: list[tuple[tuple[float, float, float], tuple[float, float, float]]] = [
    ((0.0, 0.100, 0.010), (0.077, 0.095, 0.100)),     # cranium
    ((0.0, 0.045, 0.030), (0.064, 0.075, 0.078)),     # face
    ((0.0, 0.002, 0.060), (0.050, 0.036, 0.047)),     # jaw and chin
    ((0.0, -0.016, 0.090), (0.020, 0.019, 0.023)),    # chin point
    ((0.0, 0.066, 0.104), (0.009, 0.024, 0.015)),     # nose bridge
    ((0.0, 0.043, 0.112), (0.015, 0.012, 0.017)),     # nose tip and nostrils
    ((0.0, 0.016, 0.101), (0.024, 0.011, 0.014)),     # lips
    ((0.0, 0.104, 0.080), (0.055, 0.015, 0.030)),     # brow ridge
    ((0.074, 0.072, -0.004), (0.011, 0.030, 0.019)),  # left ear
    ((-0.074, 0.072, -0.004), (0.011, 0.030, 0.019)), # right ear
]
BLEND = 0.003                              # crease rounding of the union (metres)
SOCKET_DEPTH, SOCKET_WIDTH = 0.03, 0.22   # fraction of the radius, angular width (rad) of the eye sockets
EYE_RADIUS = 0.0125
MOUTH_Y = 0.016                            # the lips meet here (relative to the head joint)
NOSE_TIP = (0.0, 0.043, 0.129)


def _radius_fn(eyes: np.ndarray):
    def fn(dirs: np.ndarray) -> np.ndarray:
        r = soft_max([ellipsoid_exit(BLOB_CENTRE, dirs, np.array(c), np.array(a)) for c, a in HEAD_ELLIPSOIDS], BLEND)
        for e in eyes:  # sockets around the eyeballs
            ed = (e - BLOB_CENTRE) / np.linalg.norm(e - BLOB_CENTRE)
            ang = np.arccos(np.clip(dirs @ ed, -1, 1))
            r = r * (1 - SOCKET_DEPTH * np.exp(-(ang / SOCKET_WIDTH) ** 2))
        return r
    return fn


def head(sk: RestSkeleton) -> Part:
    H = sk.joints[JI["head"]]
    eyes = np.array([EYE, (-EYE[0], EYE[1], EYE[2])])
    p = star_blob("head", H + BLOB_CENTRE, _radius_fn(eyes), n_lat=28, n_lon=38)
    rel = p.vertices - H
    # jaw: below the lips and in front of the ear, blended over ~1 cm
    w_jaw = smoothstep((MOUTH_Y + 0.004 - rel[:, 1]) / 0.012) * smoothstep((rel[:, 2] - 0.015) / 0.03)
    W = np.zeros((len(rel), 55))
    W[:, JI["head"]] = 1 - w_jaw
    W[:, JI["jaw"]] = w_jaw
    p.weights = W
    p.rings["jaw_band"] = np.nonzero((np.abs(rel[:, 1] - 0.052) < 0.012) & (rel[:, 2] < 0.02))[0]
    return p


def eyeball(sk: RestSkeleton, side: str) -> Part:
    c = sk.joints[JI[f"{side}_eye_smplhf"]]
    p = star_blob(f"{side}_eye", c, lambda d: np.full(len(d), EYE_RADIUS), n_lat=6, n_lon=10)
    W = np.zeros((len(p.vertices), 55))
    W[:, JI[f"{side}_eye_smplhf"]] = 1.0
    p.weights = W
    return p


def expression_fields(rel: np.ndarray) -> np.ndarray:
    """(n, 3, 3) displacements (metres per unit coefficient) of head vertices at `rel` (to the head joint).

    0: mouth open (lower lip and chin down), 1: smile (mouth corners up and out), 2: brows raised.
    """
    out = np.zeros((len(rel), 3, 3))
    front = smoothstep((rel[:, 2] - 0.05) / 0.03)
    lower = np.exp(-((rel[:, 1] - (MOUTH_Y - 0.014)) / 0.018) ** 2) * (rel[:, 1] < MOUTH_Y + 0.002)
    out[:, 1, 0] = -0.004 * front * lower
    for sx in (1.0, -1.0):
        g = np.exp(-(((rel[:, 0] - sx * 0.024) ** 2 + (rel[:, 1] - MOUTH_Y) ** 2) / 0.012**2)) * front
        out[:, 0, 1] += sx * 0.0015 * g
        out[:, 1, 1] += 0.0025 * g
        b = np.exp(-(((rel[:, 0] - sx * 0.032) ** 2 + (rel[:, 1] - 0.106) ** 2) / 0.016**2)) * front
        out[:, 1, 2] += 0.003 * b
    return out


def landmark_targets() -> np.ndarray:
    """(51, 3) points relative to the head joint, in the order of FLAME's 51 static landmarks (iBUG 17-67):
    right brow (outer->inner), left brow (inner->outer), nose bridge (4), nostrils (5), right eye (6),
    left eye (6), outer lips (12), inner lips (8). Right = -x."""
    pts: list[tuple[float, float, float]] = []
    brow = [(-0.056, 0.100, 0.088), (-0.046, 0.106, 0.098), (-0.034, 0.108, 0.104), (-0.022, 0.107, 0.108),
            (-0.010, 0.104, 0.110)]
    pts += brow + [(-x, y, z) for x, y, z in brow[::-1]]
    nx, ny, nz = NOSE_TIP
    pts += [(0.0, EYE[1] - k * (EYE[1] - ny) / 3, nz - 0.012 + 0.004 * k) for k in range(4)]  # bridge
    pts += [(-0.016, ny - 0.004, nz - 0.016), (-0.008, ny - 0.007, nz - 0.008), (0.0, ny - 0.008, nz - 0.006),
            (0.008, ny - 0.007, nz - 0.008), (0.016, ny - 0.004, nz - 0.016)]               # nostrils
    ring = [(-0.014, 0.0), (-0.006, 0.005), (0.006, 0.005), (0.014, 0.0), (0.006, -0.005), (-0.006, -0.005)]
    for sx in (-1.0, 1.0):  # right eye then left eye, each from its -x corner over the upper lid
        pts += [(EYE[0] * sx + dx, EYE[1] + dy, EYE[2] + EYE_RADIUS - 0.002) for dx, dy in ring]
    for k in range(12):  # outer lips from the right corner, over the top
        a = np.pi - 2 * np.pi * k / 12
        pts.append((0.026 * np.cos(a), MOUTH_Y + 0.011 * np.sin(a), 0.108 - 0.006 * abs(np.cos(a))))
    for k in range(8):
        a = np.pi - 2 * np.pi * k / 8
        pts.append((0.018 * np.cos(a), MOUTH_Y + 0.003 * np.sin(a), 0.110))
    return np.asarray(pts)
