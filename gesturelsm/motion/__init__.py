"""Motion representation: rotations, the SMPL-X skeleton, body regions, features and normalisation.

The names below are imported from their modules on first use, so a torch-free module of this package (the
skeleton, the regions' table) loads without torch: a command's `--help` that lists the regions loads no torch."""
from __future__ import annotations

from typing import TYPE_CHECKING

from ..lazy import lazy_names

_HOME = {
    "Normalizer": "normalize", "FEATURE_DIM": "regions", "GENERATED_REGIONS": "regions", "REGIONS": "regions",
    "Region": "regions", "join_regions": "regions", "split_regions": "regions",
    "axis_angle_to_matrix": "rotations", "axis_angle_to_rot6d": "rotations", "matrix_to_axis_angle": "rotations",
    "matrix_to_rot6d": "rotations", "rot6d_to_axis_angle": "rotations", "rot6d_to_matrix": "rotations",
    "FPS": "sequence", "MotionFileError": "sequence", "MotionSequence": "sequence", "mirror_features": "sequence",
    "JOINT_NAMES": "skeleton", "MIRROR_PERM": "skeleton", "NUM_JOINTS": "skeleton", "PARENTS": "skeleton",
    "trans_to_velocity": "translation", "velocity_to_trans": "translation",
}

if TYPE_CHECKING:
    from .normalize import Normalizer
    from .regions import FEATURE_DIM, GENERATED_REGIONS, REGIONS, Region, join_regions, split_regions
    from .rotations import (axis_angle_to_matrix, axis_angle_to_rot6d, matrix_to_axis_angle, matrix_to_rot6d,
                            rot6d_to_axis_angle, rot6d_to_matrix)
    from .sequence import FPS, MotionFileError, MotionSequence, mirror_features
    from .skeleton import JOINT_NAMES, MIRROR_PERM, NUM_JOINTS, PARENTS
    from .translation import trans_to_velocity, velocity_to_trans


__getattr__ = lazy_names(__name__, _HOME)


__all__ = [
    "Normalizer", "FEATURE_DIM", "GENERATED_REGIONS", "REGIONS", "Region", "join_regions", "split_regions",
    "axis_angle_to_matrix", "axis_angle_to_rot6d", "matrix_to_axis_angle", "matrix_to_rot6d",
    "rot6d_to_axis_angle", "rot6d_to_matrix", "FPS", "MotionFileError", "MotionSequence", "mirror_features",
    "JOINT_NAMES", "MIRROR_PERM", "NUM_JOINTS", "PARENTS", "trans_to_velocity", "velocity_to_trans",
]
