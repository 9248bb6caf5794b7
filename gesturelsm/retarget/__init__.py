"""Retargeting SMPL-X motion onto a user's character: VRM 0.x / 1.0, glTF skins with a bone-name map, BVH.

    from gesturelsm.retarget import load_character, retarget_motion
    character = load_character("avatar.vrm")              # Character: skeleton (+ glTF document, face presets)
    moved = retarget_motion(seq, character)                # Retargeted: per-frame local rotations, root motion

No Blender: numpy and torch only. See `solve.py` for the method and docs/CHARACTERS.md for its use.
"""
from .character import Character, check_usable, load_character, retarget_motion
from .errors import CharacterError
from .skeleton import Skeleton
from .solve import Ground, Retargeted, SourceBody, retarget

__all__ = ["Character", "CharacterError", "Ground", "Retargeted", "Skeleton", "SourceBody", "check_usable",
           "load_character", "retarget", "retarget_motion"]
