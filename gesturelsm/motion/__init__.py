"""Motion representation: rotations, the SMPL-X skeleton, body regions, features and normalisation."""
from .normalize import Normalizer
from .regions import FEATURE_DIM, GENERATED_REGIONS, REGIONS, Region, join_regions, split_regions
from .rotations import (axis_angle_to_matrix, axis_angle_to_rot6d, matrix_to_axis_angle, matrix_to_rot6d,
                        rot6d_to_axis_angle, rot6d_to_matrix)
from .sequence import FPS, MotionFileError, MotionSequence, mirror_features
from .skeleton import JOINT_NAMES, MIRROR_PERM, NUM_JOINTS, PARENTS
from .translation import trans_to_velocity, velocity_to_trans

__all__ = [
    "Normalizer", "FEATURE_DIM", "GENERATED_REGIONS", "REGIONS", "Region", "join_regions", "split_regions",
    "axis_angle_to_matrix", "axis_angle_to_rot6d", "matrix_to_axis_angle", "matrix_to_rot6d",
    "rot6d_to_axis_angle", "rot6d_to_matrix", "FPS", "MotionFileError", "MotionSequence", "mirror_features",
    "JOINT_NAMES", "MIRROR_PERM", "NUM_JOINTS", "PARENTS", "trans_to_velocity", "velocity_to_trans",
]
