"""Body models: the built-in SMPL-X-format mannequin, loading SMPL-X npz files, forward kinematics.

    from gesturelsm.body import load_body_model
    body = load_body_model()                 # $GESTURELSM_SMPLX_MODEL or the shipped mannequin
    out = body.forward_sequence(seq)         # vertices (T, V, 3), joints (T, 55, 3)
"""
from __future__ import annotations

from .fk import forward_kinematics, forward_kinematics_aa, skinning_transforms
from .model import BodyModel, BodyModelError, BodyOutput, load_body_model, resolve_body, resolve_model_path

__all__ = ["BodyModel", "BodyModelError", "BodyOutput", "forward_kinematics", "forward_kinematics_aa",
           "load_body_model", "resolve_body", "resolve_model_path", "skinning_transforms"]
