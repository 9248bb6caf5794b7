"""`Camera`: one pinhole camera, fixed across a clip, framed on the motion's extent (all bodies).

Conventions: world metres, y up, bodies face +z; the camera stands in front of the body (on +z) and looks
back along -z, tilted down by `elevation`, so the body's left (+x) is on the image's right. Camera space is
OpenGL's (x right, y up, looking along -z), which is what pyrender uses. Pixel coordinates: x to the right,
y downwards, (0, 0) is the top-left corner of the top-left pixel; pixel (i, j) covers [j, j+1) x [i, i+1).
The renderer and the 2D keypoint export use the same `Camera`, so keypoints land on the rendered body.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Camera:
    eye: tuple[float, float, float]       # camera centre, world metres
    target: tuple[float, float, float]    # point looked at
    yfov: float                           # vertical field of view, radians
    width: int                            # image size in pixels
    height: int
    znear: float = 0.05
    zfar: float = 100.0

    @property
    def aspect(self) -> float:
        return self.width / self.height

    @property
    def pose(self) -> np.ndarray:
        """(4, 4) camera-to-world (columns: right, up, backward, eye), as pyrender expects."""
        eye, target = np.asarray(self.eye, np.float64), np.asarray(self.target, np.float64)
        back = eye - target
        back /= np.linalg.norm(back)
        right = np.cross([0.0, 1.0, 0.0], back)
        right /= np.linalg.norm(right)
        up = np.cross(back, right)
        M = np.eye(4)
        M[:3, 0], M[:3, 1], M[:3, 2], M[:3, 3] = right, up, back, eye
        return M

    @property
    def view(self) -> np.ndarray:
        """(4, 4) world-to-camera."""
        return np.linalg.inv(self.pose)

    @property
    def focal_px(self) -> float:
        """Focal length in pixels (square pixels)."""
        return 0.5 * self.height / np.tan(0.5 * self.yfov)

    @property
    def intrinsics(self) -> np.ndarray:
        """(3, 3) K for pixel coordinates as defined in the module docstring."""
        f = self.focal_px
        return np.array([[f, 0.0, self.width / 2], [0.0, f, self.height / 2], [0.0, 0.0, 1.0]])

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        V = self.view
        return np.asarray(points, np.float64) @ V[:3, :3].T + V[:3, 3]

    def project(self, points: np.ndarray) -> np.ndarray:
        """(..., 3) world points -> (..., 2) pixel coordinates (x right, y down)."""
        pc = self.to_camera(points)
        depth = np.maximum(-pc[..., 2], 1e-9)
        f = self.focal_px
        x = self.width / 2 + f * pc[..., 0] / depth
        y = self.height / 2 - f * pc[..., 1] / depth
        return np.stack([x, y], -1)

    def ndc(self, points: np.ndarray) -> np.ndarray:
        """(..., 3) -> (..., 2) normalised device coordinates in [-1, 1] inside the image."""
        px = self.project(points)
        return np.stack([px[..., 0] / self.width * 2 - 1, 1 - px[..., 1] / self.height * 2], -1)

    def resized(self, width: int, height: int) -> "Camera":
        """Same view for another image size (the vertical field of view is kept)."""
        return Camera(self.eye, self.target, self.yfov, int(width), int(height), self.znear, self.zfar)

    @classmethod
    def fit(cls, points: np.ndarray, width: int, height: int, yfov_deg: float = 28.0,
            elevation_deg: float = 7.0, margin: float = 0.05, azimuth_deg: float = 0.0,
            reserve_top: float = 0.0) -> "Camera":
        """The closest camera of this direction and field of view that sees every point.

        points: (N, 3) world points to keep in view (e.g. the convex hull of every body's sampled vertices
        over the clip; only the hull matters). margin: fraction of the half-image kept free on each side.
        reserve_top: fraction of the image height kept free at the top (for labels). The target is moved so
        that the points' projection is centred in the remaining window.
        """
        P = np.asarray(points, np.float64).reshape(-1, 3)
        if len(P) == 0 or not np.isfinite(P).all():
            raise ValueError("camera fit needs finite points")
        if not 0.0 <= reserve_top < 0.6 or not 0.0 <= margin < 0.5:
            raise ValueError("margin must be in [0, 0.5) and reserve_top in [0, 0.6)")
        el, az = np.radians(elevation_deg), np.radians(azimuth_deg)
        back = np.array([np.cos(el) * np.sin(az), np.sin(el), np.cos(el) * np.cos(az)])
        right = np.cross([0.0, 1.0, 0.0], back)
        right /= np.linalg.norm(right)
        up = np.cross(back, right)
        t = np.tan(0.5 * np.radians(yfov_deg))
        aspect = width / height
        lx = 1.0 - margin                                       # ndc window: x in [-lx, lx], y in [lo, hi]
        hi, lo = 1.0 - margin - 2.0 * reserve_top, -(1.0 - margin)
        centre_v = 0.5 * (hi + lo)
        target = 0.5 * (P.min(0) + P.max(0))
        extent = float(np.linalg.norm(P.max(0) - P.min(0))) + 1e-3
        for i in range(8):
            rel = P - target
            x, y, z = rel @ right, rel @ up, rel @ back          # camera looks along -back
            # smallest d with every point inside the window at depth d - z
            d = max(float(np.max(np.abs(x) / (lx * t * aspect) + z)),
                    float(np.max(np.maximum(y / (hi * t), y / (lo * t)) + z)))
            d = max(d, float(z.max()) + 0.1 * extent)
            depth = d - z
            u, v = x / (depth * t * aspect), y / (depth * t)     # ndc
            du, dv = 0.5 * (u.max() + u.min()), 0.5 * (v.max() + v.min()) - centre_v
            if (abs(du) < 1e-3 and abs(dv) < 1e-3) or i == 7:
                break
            mean_depth = float(np.median(depth))                # move the target to centre the projection
            target = target + right * du * mean_depth * t * aspect + up * dv * mean_depth * t
        eye = target + back * d
        znear = max(0.01, 0.5 * float((d - z).min()))
        return cls(tuple(float(a) for a in eye), tuple(float(a) for a in target), float(np.radians(yfov_deg)),
                   int(width), int(height), znear, float(d + 4 * extent + 20.0))
