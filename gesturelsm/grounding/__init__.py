"""Feet on the ground: foot contacts, planted feet by two-bone leg IK, drift removal, the root on the floor.

    from gesturelsm.grounding import ground_motion
    res = ground_motion(seq)                 # MotionSequence -> GroundingResult(motion, contacts, note)
    res.motion.save("grounded.npz")          # res.note says why a motion was left as it was (then unchanged)

What it does to a motion (solve.py): slow drift leaves the root's horizontal path (weight shifts and small steps
stay) and the path stays inside a standing area; a foot that is low and slow is planted where it landed, level on
the floor, and stays there until it lifts (hysteresis, contacts.py); the legs reach their feet by analytic two-bone
IK (hip and knee; the ankle turns the foot level); corrections blend in and out smoothly; the root's height
follows the lowest planted foot so that it touches the floor. Only the root translation and the hips', knees' and
ankles' rotations change: the pelvis orientation, spine, arms, hands, head, face, toes and expressions are the
input's, bit for bit.

The layers, for reuse (live mode grounds chunk by chunk; a character's skeleton is grounded like the body's):

| layer | module | offline | causal |
|---|---|---|---|
| skeleton: parents, rest joints, legs, sole heights; legs' FK | rig.py `LegRig`, `forward`, `smplx_rig` | - | - |
| contacts from height and speed, hysteresis | contacts.py | `detect_contacts` (T, F) | `ContactDetector.step` |
| drift out of the root's horizontal path | drift.py | `remove_drift` (zero phase) | `DriftRemover.run` (chunks) |
| two-bone leg IK, per frame, batched | ik.py `two_bone` | same | same |
| where the feet go: plants, corrections, level blend | targets.py | whole take | - |
| the whole take on a LegRig | solve.py `ground_legs` | yes | - |
| an SMPL-X MotionSequence on a body model | motion.py `ground_motion` | yes | - |

Rig convention (rig.py): local rotations (T, J, 3, 3) act in the parent's frame about the joint's rest position,
rest frames aligned with the world (metres, y up, facing +z, left +x; identity = the rest pose, standing on a flat
floor with the feet level); each leg is hip -> knee -> ankle -> toe, each the previous one's child; positions are
the root joint's world position (T, 3). Floor: y = `GroundingSettings.floor` (0: BEAT2's floor and the page
player's).
"""
from __future__ import annotations

from .contacts import ContactDetector, ContactParams, causal_contacts, detect_contacts
from .drift import DriftParams, DriftRemover, remove_drift
from .ik import two_bone
from .motion import CHANGED_JOINTS, GroundingResult, ground_motion, rig_of
from .rig import Leg, LegRig, forward, smplx_rig
from .solve import Grounded, GroundingSettings, ground_legs

__all__ = ["CHANGED_JOINTS", "ContactDetector", "ContactParams", "DriftParams", "DriftRemover", "Grounded",
           "GroundingResult", "GroundingSettings", "Leg", "LegRig", "causal_contacts", "detect_contacts", "forward",
           "ground_legs", "ground_motion", "remove_drift", "rig_of", "smplx_rig", "two_bone"]
