"""The rotation operations grounding uses, on numpy float64 arrays batched over any leading dims (matrices act on
column vectors). The general ones are motion/rotations.py's numpy twins, under the short names grounding has always
used (`exp`, `log`, `between`, `slerp`); `about` and `yaw_only` are grounding's own."""
from __future__ import annotations

import numpy as np

from ..motion.rotations import EPS
from ..motion.rotations import unit_np as normalize
from ..motion.rotations import axis_angle_to_matrix_np as exp
from ..motion.rotations import matrix_to_axis_angle_np as log
from ..motion.rotations import rotation_between_np as between
from ..motion.rotations import slerp_np as slerp


def about(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotation by `angle` (...) radians about the unit `axis` (..., 3)."""
    return exp(axis * np.asarray(angle)[..., None])


def yaw_only(R: np.ndarray, forward: np.ndarray) -> np.ndarray:
    """(..., 3, 3) the rotation about the vertical (y) axis that turns the horizontal `forward` (3,) the way R turns
    it, seen from above: R with its tilt (pitch and roll) removed."""
    f = R @ forward
    yaw = np.arctan2(f[..., 0], f[..., 2]) - np.arctan2(forward[0], forward[2])
    return about(np.broadcast_to(np.array([0.0, 1.0, 0.0]), f.shape), yaw)


__all__ = ["EPS", "about", "between", "exp", "log", "normalize", "slerp", "yaw_only"]
