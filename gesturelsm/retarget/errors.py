"""The error a character file raises when it cannot be used: one line that names the file and the problem."""
from __future__ import annotations

from ..errors import InputError


class CharacterError(InputError):
    """A character (VRM / glTF / BVH) that cannot be retargeted onto; the message says why."""
