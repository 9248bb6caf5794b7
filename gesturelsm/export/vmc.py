"""A motion as VMC protocol frames (the Virtual Motion Capture Protocol: OSC over UDP), the live format of VSeeFace,
VNyan, Warudo, VMagicMirror, EVMC4U (Unity), VRM4U / VMC4UE (Unreal) and Blender add-ons (docs/ENGINES.md).

Per frame, one OSC bundle:
    /VMC/Ext/Root/Pos  "root" p.x p.y p.z q.x q.y q.z q.w     the avatar's root: at the origin, unrotated
    /VMC/Ext/Bone/Pos  name   p.x p.y p.z q.x q.y q.z q.w     55 bones, Unity HumanBodyBones names, local pose
    /VMC/Ext/Blend/Val name   value                           VRM 0.x presets (A I U E O Blink_L Blink_R), and
                                                              with perfect sync the 52 ARKit names
    /VMC/Ext/Blend/Apply
    /VMC/Ext/OK        1                                      loaded, calibrated
    /VMC/Ext/T         seconds since the stream began
The bones' rotations are local (relative to the parent bone) and relative to a normalised T-pose: every bone's
rest rotation is identity (the VRM 0.x convention receivers expect), so a T-pose frame sends identity rotations.
The T-pose is the body's own rest skeleton with its arms straightened along the body's sides (x) and its legs
straight down (the mannequin's rest is such a T-pose already; hands and fingers keep their rest; `tpose_skeleton`);
the motion is put on it by the character retargeter (world bone directions, `retarget.solve`), so each received bone
points where the motion's bone points. Positions are the T-pose's bone offsets in metres; the Hips' is its place
above the avatar's root (soles on y = 0) moving with the motion's root translation.
Handedness: the body's frame is right-handed (y up, facing +z, its left +x); Unity's is left-handed (y up, facing
+z, the avatar's left -x): positions go as (-x, y, z) and quaternions (x, y, z, w) as (x, -y, -z, w).

    frames = vmc_frames(seq)                       # VmcFrames: (T, 55) local poses in Unity's frame, blendshapes
    packet = vmc_bundle(frames, 0, 0.0)            # bytes: one OSC bundle, ready for a UDP socket
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pythonosc.osc_bundle_builder import IMMEDIATELY, OscBundleBuilder
from pythonosc.osc_message_builder import OscMessageBuilder

from ..body.model import resolve_body
from ..motion.sequence import MotionSequence
from ..motion.skeleton import JOINT_NAMES, PARENTS
from ..retarget import Ground, Skeleton, SourceBody, retarget
from ..retarget.solve import prepare
from .alive import Blinker, face_presets
from .arkit import ARKIT_NAMES, arkit_face
from .glb import matrix_to_quaternion_xyzw

# Unity's HumanBodyBones, in the enum's order (LastBone excluded): 55 bones
HUMAN_BODY_BONES: tuple[str, ...] = (
    "Hips", "LeftUpperLeg", "RightUpperLeg", "LeftLowerLeg", "RightLowerLeg", "LeftFoot", "RightFoot", "Spine",
    "Chest", "Neck", "Head", "LeftShoulder", "RightShoulder", "LeftUpperArm", "RightUpperArm", "LeftLowerArm",
    "RightLowerArm", "LeftHand", "RightHand", "LeftToes", "RightToes", "LeftEye", "RightEye", "Jaw",
    "LeftThumbProximal", "LeftThumbIntermediate", "LeftThumbDistal", "LeftIndexProximal", "LeftIndexIntermediate",
    "LeftIndexDistal", "LeftMiddleProximal", "LeftMiddleIntermediate", "LeftMiddleDistal", "LeftRingProximal",
    "LeftRingIntermediate", "LeftRingDistal", "LeftLittleProximal", "LeftLittleIntermediate", "LeftLittleDistal",
    "RightThumbProximal", "RightThumbIntermediate", "RightThumbDistal", "RightIndexProximal",
    "RightIndexIntermediate", "RightIndexDistal", "RightMiddleProximal", "RightMiddleIntermediate",
    "RightMiddleDistal", "RightRingProximal", "RightRingIntermediate", "RightRingDistal", "RightLittleProximal",
    "RightLittleIntermediate", "RightLittleDistal", "UpperChest")
assert len(HUMAN_BODY_BONES) == 55 and len(set(HUMAN_BODY_BONES)) == 55

# SMPL-X joint -> HumanBodyBones: one bone for each of the 55 joints
UNITY_BONE: dict[str, str] = {
    "pelvis": "Hips", "spine1": "Spine", "spine2": "Chest", "spine3": "UpperChest", "neck": "Neck", "head": "Head",
    "jaw": "Jaw", "left_eye_smplhf": "LeftEye", "right_eye_smplhf": "RightEye"}
for _s, _S in (("left", "Left"), ("right", "Right")):
    UNITY_BONE.update({
        f"{_s}_hip": f"{_S}UpperLeg", f"{_s}_knee": f"{_S}LowerLeg", f"{_s}_ankle": f"{_S}Foot",
        f"{_s}_foot": f"{_S}Toes", f"{_s}_collar": f"{_S}Shoulder", f"{_s}_shoulder": f"{_S}UpperArm",
        f"{_s}_elbow": f"{_S}LowerArm", f"{_s}_wrist": f"{_S}Hand"})
    for _f, _F in (("thumb", "Thumb"), ("index", "Index"), ("middle", "Middle"), ("ring", "Ring"),
                   ("pinky", "Little")):
        for _k, _seg in enumerate(("Proximal", "Intermediate", "Distal"), 1):
            UNITY_BONE[f"{_s}_{_f}{_k}"] = f"{_S}{_F}{_seg}"
assert sorted(UNITY_BONE) == sorted(JOINT_NAMES) and set(UNITY_BONE.values()) == set(HUMAN_BODY_BONES)

VRM_PRESETS = ("A", "I", "U", "E", "O", "Blink_L", "Blink_R")     # the VRM 0.x expression presets sent
_PRESET_OF = {"A": "aa", "I": "ih", "U": "ou", "E": "ee", "O": "oh"}
_STRAIGHT = {"elbow", "wrist"}   # the upper arm and forearm along the side (x) in the T-pose


def _straightened(joint: str) -> np.ndarray | None:
    """The T-pose direction of the bone ending at `joint` (from its parent), or None: keep the rest offset."""
    side, _, part = joint.partition("_")
    part = part.rstrip("123")
    if side not in ("left", "right"):
        return None
    sx = 1.0 if side == "left" else -1.0
    if part in ("knee", "ankle"):
        return np.array([0.0, -1.0, 0.0])
    if part in _STRAIGHT:
        return np.array([sx, 0.0, 0.0])
    return None


def tpose_skeleton(body=None) -> Skeleton:
    """The normalised T-pose (module docstring) as a retargeting skeleton: the 55 SMPL-X joints, metres, identity
    rest rotations, the body's own bone lengths; upper arms and forearms along +-x, legs along -y; its soles on
    y = 0 (the hips about 0.9 m up, where an avatar's are)."""
    body = resolve_body(body)
    rest = np.asarray(body.rest_joints(), np.float64)
    pos = rest.copy()
    for j, p in enumerate(PARENTS):
        if p < 0:
            continue
        offset = rest[j] - rest[p]
        d = _straightened(JOINT_NAMES[j])
        pos[j] = pos[p] + (offset if d is None else d * np.linalg.norm(offset))
    pos[:, 1] -= float(np.asarray(body.rest_vertices())[:, 1].min())      # standing on y = 0, as avatars do
    parents = np.asarray(PARENTS)
    local = np.array([pos[j] - (pos[p] if p >= 0 else 0.0) for j, p in enumerate(parents)])
    n = len(JOINT_NAMES)
    return Skeleton(names=[UNITY_BONE[j] for j in JOINT_NAMES], parents=parents, translation=local,
                    rotation=np.repeat(np.eye(3)[None], n, 0), scale=np.ones((n, 3)),
                    bones={j: i for i, j in enumerate(JOINT_NAMES)}, source="VMC T-pose", kind="vmc")


def to_unity_position(p: np.ndarray) -> np.ndarray:
    """(..., 3) right-handed (x left, y up, z forward) -> Unity's left-handed frame: (-x, y, z)."""
    return np.asarray(p, np.float64) * np.array([-1.0, 1.0, 1.0])


def to_unity_quaternion(q: np.ndarray) -> np.ndarray:
    """(..., 4) x, y, z, w right-handed -> Unity's left-handed frame: (x, -y, -z, w)."""
    return np.asarray(q, np.float64) * np.array([1.0, -1.0, -1.0, 1.0])


@dataclass
class VmcFrames:
    """A motion ready to send: per frame (T) the 55 bones' local positions (T, 55, 3) and rotations (T, 55, 4),
    x y z w, in Unity's frame, in HUMAN_BODY_BONES order (`bones`); blendshape `blend_names` and their values
    (T, B); `fps`; `ground` carries the root's reference on to the next chunk of a stream."""
    bones: tuple[str, ...]
    positions: np.ndarray
    rotations: np.ndarray
    blend_names: tuple[str, ...]
    blends: np.ndarray
    fps: int
    ground: Ground | None = None

    @property
    def num_frames(self) -> int:
        return len(self.rotations)


class VmcMaker:
    """Makes VmcFrames from motion, one take or chunk after chunk of a stream (the root's reference, the blinks'
    timing carry over, so chunks join without jumps). `perfect_sync`: the 52 ARKit blendshapes too."""

    def __init__(self, body=None, perfect_sync: bool = False, seed: int = 0) -> None:
        self.body = resolve_body(body)
        self.perfect_sync = perfect_sync
        self.skeleton = tpose_skeleton(self.body)
        self.source = SourceBody.of(self.body)
        self.setup = prepare(self.skeleton, self.source)
        self.ground: Ground | None = None
        self.blinker: Blinker | None = None
        self.seed = seed
        order = [self.skeleton.names.index(b) for b in HUMAN_BODY_BONES]
        self._order = np.asarray(order)

    def frames(self, seq: MotionSequence) -> VmcFrames:
        """The next frames (the whole take, or the stream's next chunk)."""
        if self.blinker is None:
            self.blinker = Blinker(seq.fps, self.seed)
        r = retarget(seq, self.skeleton, self.source, self.ground, self.setup)
        self.ground = r.ground
        T = r.num_frames
        quats = matrix_to_quaternion_xyzw(r.local_rotation)[:, self._order]             # (T, 55, 4)
        pos = np.repeat(self.skeleton.translation[None, self._order], T, 0)
        pos[:, 0] = r.root_translation
        names, values = self._blends(seq)
        return VmcFrames(HUMAN_BODY_BONES, to_unity_position(pos), to_unity_quaternion(quats), names, values,
                         int(seq.fps), r.ground)

    def _blends(self, seq: MotionSequence) -> tuple[tuple[str, ...], np.ndarray]:
        T = seq.num_frames
        presets, blink = face_presets(self.body, seq, self.blinker)
        cols = [presets[_PRESET_OF[p]] for p in VRM_PRESETS[:5]] + [blink, blink]
        names = VRM_PRESETS
        if self.perfect_sync:
            face = arkit_face(seq, self.body, blinks=None)
            w = face.weights.copy()
            for side in ("Left", "Right"):
                k = ARKIT_NAMES.index(f"EyeBlink{side}")
                w[:, k] = np.maximum(w[:, k], blink)
            cols += list(w.T)
            names = names + ARKIT_NAMES
        return names, np.stack(cols, 1).reshape(T, len(names))


def vmc_frames(seq: MotionSequence, body=None, perfect_sync: bool = False, seed: int = 0) -> VmcFrames:
    """One take as VmcFrames (module docstring)."""
    return VmcMaker(body, perfect_sync, seed).frames(seq)


def _message(address: str, *args) -> object:
    m = OscMessageBuilder(address)
    for a in args:
        m.add_arg(a, "s" if isinstance(a, str) else "i" if isinstance(a, int) else "f")
    return m.build()


def vmc_bundle(frames: VmcFrames, t: int, seconds: float) -> bytes:
    """Frame `t` of `frames` as one OSC bundle (module docstring); `seconds`: the stream's clock for /VMC/Ext/T."""
    b = OscBundleBuilder(IMMEDIATELY)
    b.add_content(_message("/VMC/Ext/Root/Pos", "root", 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0))
    P, Q = frames.positions[t], frames.rotations[t]
    for i, name in enumerate(frames.bones):
        b.add_content(_message("/VMC/Ext/Bone/Pos", name, *(float(x) for x in P[i]), *(float(x) for x in Q[i])))
    for name, v in zip(frames.blend_names, frames.blends[t]):
        b.add_content(_message("/VMC/Ext/Blend/Val", name, float(v)))
    b.add_content(_message("/VMC/Ext/Blend/Apply"))
    b.add_content(_message("/VMC/Ext/OK", 1))
    b.add_content(_message("/VMC/Ext/T", float(seconds)))
    return b.build().dgram


__all__ = ["HUMAN_BODY_BONES", "UNITY_BONE", "VRM_PRESETS", "VmcFrames", "VmcMaker", "tpose_skeleton", "vmc_bundle",
           "vmc_frames"]
