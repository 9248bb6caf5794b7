"""The generated face as Apple ARKit's 52 blendshape weights per frame, plus head and eye rotations, for face rigs
in Unreal (MetaHuman, Live Link Face), Unity and Blender that take ARKit's face coefficients.

Measured like `retarget/face.py` measures VRM visemes: the motion's jaw pose and expression coefficients are put
on the body's head (every other joint at rest, so the head frame is the rest frame: x the body's left, y up, z
forward) and its 51 facial landmarks (iBUG 17-67) are read per frame. Two references per frame: `lm` (jaw +
expressions) and `jaw` (the same jaw pose, expressions 0); and the neutral face (jaw closed, expressions 0).
Scales: the neutral mouth width w (outer corners); a displacement of M = FULL_MOVE * w (about 5 mm on an adult
face) is a full weight of 1; the inner-lip gap at alive.py's JAW_FULL jaw rotation (0.12 rad: a face capture's scale
for speech) is a full opening. Every weight
is clipped to [0, 1]. Left / Right are the face's own sides (the body's left is +x), as ARKit names them.

    JawOpen            inner-lip gap of `jaw` over the neutral gap, / (gap at JAW_FULL - neutral gap); the gap
                       as face.py's (inner lips 61-63 to 67-65) but in the face's mid-plane (up and forward)
    JawLeft / Right    sideways shift of the lower-lip centre in `jaw` vs neutral (to the face's left: JawLeft),
                       / the shift that JAW_SIDE rad of jaw rotation about the vertical axis gives
    MouthClose         how much less the lips part than the jaw alone parts them (gap of `jaw` - gap of `lm`, on
                       the JawOpen scale), at most JawOpen
    MouthFunnel/Pucker the mouth narrowed: s = (corner distance of `lm` - of `jaw`) / (face.py's FULL_SPREAD w);
                       r = max(-s, 0) split by the lips' opening o (JawOpen's scale on
                       `lm`): Funnel = r o, Pucker = r (1 - o)
    MouthLeft / Right  sideways shift of the lips' centre (20 lip landmarks) in `lm` vs `jaw`, / M
    MouthSmile / Frown per corner: its rise in `lm` vs `jaw` minus the upper-lip centre's rise, / M; up Smile,
                       down Frown (the upper lip is the one neither the jaw nor a lowered lower lip moves)
    MouthStretch       per corner: its outward shift in `lm` vs `jaw`, / (FULL_SPREAD w / 2); a smile that
                       widens the mouth reads as stretch too
    MouthUpperUp       per side: upper-lip landmarks (outer two + inner one) up in `lm` vs `jaw`, / M
    MouthLowerDown     per side: lower-lip landmarks down in `lm` vs `jaw`, / M
    BrowInnerUp        the four inner brow landmarks (iBUG 20-23) up vs `jaw`, / M
    BrowOuterUp        per side: the two outer brow landmarks (iBUG 17-18 right, 25-26 left) up, / M
    BrowDown           per side: the five brow landmarks down, / M
    EyeBlink           per eye: face.py's blink rule (eyelid closure vs the neutral gap, closures under
                       BLINK_FROM read as open); where the model never closes the eyelids past 0.5, procedural
                       blinks over it (alive.py: about 17 a minute, irregular, some waiting for a closed mouth)
    EyeWide            per eye: eyelid gap opened beyond the neutral gap, full at +EYE_WIDE_FULL of it
    EyeLookIn/Out/Up/Down  per eye, from its joint's yaw / pitch (below), full at EYE_LOOK_FULL rad
Stay 0 (nothing on the body's landmarks or joints measures them): EyeSquint, JawForward, MouthRollLower/Upper,
MouthShrugLower/Upper, MouthPress, MouthDimple, CheekPuff, CheekSquint, NoseSneer, TongueOut.

Rotations, radians, intrinsic yaw-pitch-roll (R = Ry(yaw) Rx(pitch) Rz(roll)): yaw > 0 turns the face to its
own left, pitch > 0 tips it down (chin to chest), roll > 0 tilts the top of the head to its right; all 0 for the
speaker's neutral head (alive.py: the mean head orientation of BEAT2's take 2_scott_0_1_1, 15 degrees down and
12 to the right of the rest pose's upright, forward-facing head).
HeadYaw/Pitch/Roll: the `head` joint's world orientation relative to the body's facing direction (the pelvis's
heading about the vertical axis), so turning the whole body is not a head turn but bending the neck or the spine
is. Left/RightEye*: the eye joint's rotation relative to the head and to the speaker's neutral eye (2 degrees or less).

Which body drives what: the built-in mannequin's three expressions (mouth open, smile, brows raised; negative
coefficients reverse them) move the lower lip, the mouth corners and the brows (the brows' field lifts the upper
lids a little); with its jaw they drive JawOpen/Left/Right, MouthClose, MouthLowerDown/UpperUp, MouthSmile/Frown,
MouthStretch/Pucker, BrowInnerUp/OuterUp/Down and EyeWide. Its eyelids never close, its lips never funnel and its
fields are symmetric, so EyeBlink, MouthFunnel and MouthLeft/Right stay near 0 on it. An SMPL-X model file with
FLAME's expression basis moves every landmark and drives all the measured blendshapes.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..body.model import resolve_body
from ..errors import BodyModelError
from ..motion.sequence import MotionSequence
from ..motion.skeleton import JOINT_INDEX, PARENTS
from ..retarget.face import BLINK_FROM, CORNERS, FULL_SPREAD, INNER_LOWER, INNER_UPPER, face_landmarks, landmark_gap
from .alive import JAW_FULL, Blinker, blink_free, neutral_eye, neutral_head, pause_gate, with_blinks

# Live Link Face's CSV column order and spelling (ARKit's names, capitalised)
ARKIT_NAMES: tuple[str, ...] = (
    "EyeBlinkLeft", "EyeLookDownLeft", "EyeLookInLeft", "EyeLookOutLeft", "EyeLookUpLeft", "EyeSquintLeft",
    "EyeWideLeft", "EyeBlinkRight", "EyeLookDownRight", "EyeLookInRight", "EyeLookOutRight", "EyeLookUpRight",
    "EyeSquintRight", "EyeWideRight", "JawForward", "JawRight", "JawLeft", "JawOpen", "MouthClose", "MouthFunnel",
    "MouthPucker", "MouthRight", "MouthLeft", "MouthSmileLeft", "MouthSmileRight", "MouthFrownLeft",
    "MouthFrownRight", "MouthDimpleLeft", "MouthDimpleRight", "MouthStretchLeft", "MouthStretchRight",
    "MouthRollLower", "MouthRollUpper", "MouthShrugLower", "MouthShrugUpper", "MouthPressLeft", "MouthPressRight",
    "MouthLowerDownLeft", "MouthLowerDownRight", "MouthUpperUpLeft", "MouthUpperUpRight", "BrowDownLeft",
    "BrowDownRight", "BrowInnerUp", "BrowOuterUpLeft", "BrowOuterUpRight", "CheekPuff", "CheekSquintLeft",
    "CheekSquintRight", "NoseSneerLeft", "NoseSneerRight", "TongueOut")
HEAD_NAMES = ("HeadYaw", "HeadPitch", "HeadRoll")
EYE_NAMES = ("LeftEyeYaw", "LeftEyePitch", "LeftEyeRoll", "RightEyeYaw", "RightEyePitch", "RightEyeRoll")
assert len(ARKIT_NAMES) == 52 and len(set(ARKIT_NAMES)) == 52

# the mouth's speech shapes, eased shut in the pauses of a motion that keeps its words (alive.pause_gate)
SPEECH_SHAPES = [ARKIT_NAMES.index(n) for n in (
    "JawOpen", "MouthClose", "MouthFunnel", "MouthPucker", "MouthStretchLeft", "MouthStretchRight",
    "MouthUpperUpLeft", "MouthUpperUpRight", "MouthLowerDownLeft", "MouthLowerDownRight")]
FULL_MOVE = 0.10          # landmark displacement (fraction of the neutral mouth width) = weight 1
JAW_SIDE = 0.15           # radians of jaw rotation about the vertical axis = JawLeft / JawRight 1
EYE_WIDE_FULL = 0.30      # eyelid gap opened by this fraction of the neutral gap = EyeWide 1
EYE_LOOK_FULL = np.radians(30.0)   # eye rotation = EyeLook* 1
# indices into the 51 landmarks (iBUG 17-67 -> 0-50); right = the face's right (-x)
BROW_RIGHT, BROW_LEFT = [0, 1, 2, 3, 4], [5, 6, 7, 8, 9]
BROW_INNER, BROW_OUTER_RIGHT, BROW_OUTER_LEFT = [3, 4, 5, 6], [0, 1], [8, 9]
LIDS = {"Right": ([20, 21], [24, 23]), "Left": ([26, 27], [30, 29])}
LIPS = list(range(31, 51))
UPPER_CENTRE, LOWER_CENTRE = [34, 45], [40, 49]
UPPER = {"Right": [32, 33, 44], "Left": [35, 36, 46]}
LOWER = {"Right": [41, 42, 50], "Left": [38, 39, 48]}
CORNER = {"Right": CORNERS[0], "Left": CORNERS[1]}
SIDE = {"Right": -1.0, "Left": 1.0}              # the face's own side, as +-x


@dataclass(frozen=True)
class ArkitFace:
    """Per frame: `weights` (T, 52) in ARKIT_NAMES order, in [0, 1]; `head` (T, 3) HeadYaw/Pitch/Roll and `eyes`
    (T, 6) Left/Right eye yaw, pitch, roll, radians (module docstring); `fps` frames per second; `timecodes` the
    Live Link Face timecode of each row when read from a file, else empty."""
    weights: np.ndarray
    head: np.ndarray
    eyes: np.ndarray
    fps: int
    timecodes: tuple[str, ...] = ()

    @property
    def num_frames(self) -> int:
        return len(self.weights)

    def weight(self, name: str) -> np.ndarray:
        """(T,) one blendshape's weights by its ARKit name (any capitalisation)."""
        low = [n.lower() for n in ARKIT_NAMES]
        if name.lower() not in low:
            raise KeyError(f"{name!r} is not an ARKit blendshape name")
        return self.weights[:, low.index(name.lower())]


def _lip_gap(lm: np.ndarray) -> np.ndarray:
    """The inner-lip gap in the face's mid-plane (up and forward: a sideways jaw shift is not an opening)."""
    return landmark_gap(lm, INNER_UPPER, INNER_LOWER, slice(1, 3))


def landmark_weights(body, poses: np.ndarray, expressions: np.ndarray | None = None, betas=None
                     ) -> dict[str, np.ndarray]:
    """{ARKit name: (T,) weight in [0, 1]} for the blendshapes measured on the facial landmarks (module
    docstring); `body` has the 51 landmarks (the mannequin or an SMPL-X file), poses (T, 165)."""
    poses = np.asarray(poses, np.float64).reshape(len(poses), -1)
    j = 3 * JOINT_INDEX["jaw"]
    jaw_pose = poses[:, j:j + 3]
    ref = face_landmarks(body, np.array([[0.0, 0, 0], [JAW_FULL, 0, 0], [0, JAW_SIDE, 0]]), None, betas)
    jaw = face_landmarks(body, jaw_pose, None, betas)
    moved = expressions is not None and np.any(np.asarray(expressions) != 0)
    lm = face_landmarks(body, jaw_pose, expressions, betas) if moved else jaw
    neutral = ref[0]
    width = lambda x: np.linalg.norm(x[..., CORNERS[0], :] - x[..., CORNERS[1], :], axis=-1)  # noqa: E731
    w0 = float(width(neutral))
    move = FULL_MOVE * w0
    gap0, gap_wide = _lip_gap(ref[:2])
    full_gap = max(gap_wide - gap0, 1e-9)
    jaw_gap, lip_gap = _lip_gap(jaw), _lip_gap(lm)
    out: dict[str, np.ndarray] = {}
    out["JawOpen"] = (jaw_gap - gap0) / full_gap
    side_ref = max(abs(float(ref[2, LOWER_CENTRE, 0].mean() - neutral[LOWER_CENTRE, 0].mean())), 1e-9)
    jaw_x = (jaw[:, LOWER_CENTRE, 0].mean(-1) - neutral[LOWER_CENTRE, 0].mean()) / side_ref
    out["JawLeft"], out["JawRight"] = jaw_x, -jaw_x
    out["MouthClose"] = np.minimum((jaw_gap - lip_gap) / full_gap, np.clip(out["JawOpen"], 0.0, 1.0))
    d = lm - jaw                                                          # (T, 51, 3) what the expressions move
    narrow = np.maximum(-(width(lm) - width(jaw)) / (FULL_SPREAD * w0), 0.0)
    o = np.clip((lip_gap - gap0) / full_gap, 0.0, 1.0)
    out["MouthFunnel"], out["MouthPucker"] = narrow * o, narrow * (1.0 - o)
    mouth_x = d[:, LIPS, 0].mean(-1) / move
    out["MouthLeft"], out["MouthRight"] = mouth_x, -mouth_x
    upper_rise = d[:, UPPER_CENTRE, 1].mean(-1)
    for side, sx in SIDE.items():
        rise = (d[:, CORNER[side], 1] - upper_rise) / move
        out[f"MouthSmile{side}"], out[f"MouthFrown{side}"] = rise, -rise
        out[f"MouthStretch{side}"] = sx * d[:, CORNER[side], 0] / (FULL_SPREAD * w0 / 2)
        out[f"MouthUpperUp{side}"] = d[:, UPPER[side], 1].mean(-1) / move
        out[f"MouthLowerDown{side}"] = -d[:, LOWER[side], 1].mean(-1) / move
        brow = BROW_LEFT if side == "Left" else BROW_RIGHT
        outer = BROW_OUTER_LEFT if side == "Left" else BROW_OUTER_RIGHT
        out[f"BrowOuterUp{side}"] = d[:, outer, 1].mean(-1) / move
        out[f"BrowDown{side}"] = -d[:, brow, 1].mean(-1) / move
        lid0 = max(float(landmark_gap(neutral, *LIDS[side])), 1e-9)
        lid = landmark_gap(lm, *LIDS[side]) / lid0
        out[f"EyeBlink{side}"] = ((1.0 - lid) - BLINK_FROM) / (1.0 - BLINK_FROM)
        out[f"EyeWide{side}"] = (lid - 1.0) / EYE_WIDE_FULL
    out["BrowInnerUp"] = d[:, BROW_INNER, 1].mean(-1) / move
    return {k: np.clip(v, 0.0, 1.0) + 0.0 for k, v in out.items()}


def _yaw_pitch_roll(rot: Rotation) -> np.ndarray:
    """(T, 3) intrinsic Y-X-Z angles: yaw about up, pitch about the left axis (+ = down), roll about forward."""
    return rot.as_euler("YXZ")


def global_rotations(poses: np.ndarray, joint: str) -> Rotation:
    """The joint's world orientation per frame: its chain's local rotations (SMPL-X rest frames are the world's)."""
    aa = np.asarray(poses, np.float64).reshape(len(poses), -1, 3)
    chain, j = [], JOINT_INDEX[joint]
    while j >= 0:
        chain.append(j)
        j = PARENTS[j]
    rot = Rotation.from_rotvec(aa[:, chain[-1]])
    for k in reversed(chain[:-1]):
        rot = rot * Rotation.from_rotvec(aa[:, k])
    return rot


def head_rotation(poses: np.ndarray, neutral: bool = True) -> np.ndarray:
    """(T, 3) HeadYaw, HeadPitch, HeadRoll (radians): the head relative to the pelvis's heading and (`neutral`) to
    the speaker's neutral head (module docstring); neutral=False: to the rest pose's upright head."""
    aa = np.asarray(poses, np.float64).reshape(len(poses), -1, 3)
    forward = Rotation.from_rotvec(aa[:, 0]).apply([0.0, 0.0, 1.0])
    heading = np.arctan2(forward[:, 0], forward[:, 2])
    facing = Rotation.from_rotvec(np.stack([np.zeros_like(heading), heading, np.zeros_like(heading)], -1))
    rot = facing.inv() * global_rotations(poses, "head")
    return _yaw_pitch_roll(neutral_head(rot) if neutral else rot)


def eye_rotations(poses: np.ndarray, neutral: bool = True) -> np.ndarray:
    """(T, 6) LeftEyeYaw/Pitch/Roll, RightEyeYaw/Pitch/Roll: the SMPL-X eye joints relative to the head (and, with
    `neutral`, to the speaker's neutral eyes)."""
    aa = np.asarray(poses, np.float64).reshape(len(poses), -1, 3)
    eye = lambda s: Rotation.from_rotvec(aa[:, JOINT_INDEX[f"{s}_eye_smplhf"]])    # noqa: E731
    return np.concatenate([_yaw_pitch_roll(neutral_eye(eye(s), k) if neutral else eye(s))
                           for k, s in enumerate(("left", "right"))], -1)


def _eye_look(eyes: np.ndarray) -> dict[str, np.ndarray]:
    """EyeLook* from the eye angles: Out = towards the eye's own side, In = towards the nose, Up = pitch < 0."""
    out = {}
    for k, side in enumerate(("Left", "Right")):
        yaw, pitch = eyes[:, 3 * k] * SIDE[side] / EYE_LOOK_FULL, eyes[:, 3 * k + 1] / EYE_LOOK_FULL
        out.update({f"EyeLookOut{side}": yaw, f"EyeLookIn{side}": -yaw,
                    f"EyeLookUp{side}": -pitch, f"EyeLookDown{side}": pitch})
    return {k: np.clip(v, 0.0, 1.0) + 0.0 for k, v in out.items()}


def arkit_face(seq: MotionSequence, body=None, blinks: bool = True, blinker: Blinker | None = None,
               neutral: bool = True) -> ArkitFace:
    """The motion's face as ARKit blendshape weights with head and eye rotations (module docstring). `body`: a
    BodyModel, a model path, or None for $GESTURELSM_SMPLX_MODEL / the built-in mannequin. `blinks`: procedural
    blinks where the model does not blink (alive.py), from `blinker` (a stream's, carried over chunks) or a new
    one seeded 0; False: the eyelids as measured. `neutral`: head and eye angles relative to the speaker's neutral
    (False: to the rest pose). When `seq` keeps its words, the mouth's speech shapes are shut in the pauses and
    blinks favour word borders (alive.py); without words the face is as measured."""
    body = resolve_body(body)
    if len(body.module.lmk_faces_idx) != 51:
        raise BodyModelError(f"the body model {body.path.name} has no 51 facial landmarks to measure the face on")
    poses = np.asarray(seq.poses, np.float64)
    T = len(poses)
    eyes = eye_rotations(poses, neutral) if T else np.zeros((0, 6))
    measured = landmark_weights(body, poses, seq.expressions, seq.betas) if T else {}
    measured.update(_eye_look(eyes))
    weights = np.zeros((T, len(ARKIT_NAMES)))
    for i, name in enumerate(ARKIT_NAMES):
        if name in measured:
            weights[:, i] = measured[name]
    gate = pause_gate(seq.words, T, seq.fps)
    if gate is not None:                                  # the motion keeps its words: the mouth shut in pauses
        weights[:, SPEECH_SHAPES] *= gate[:, None]
    if blinks and T:
        blinker = blinker if blinker is not None else Blinker(int(seq.fps))
        mouth = weights[:, ARKIT_NAMES.index("JawOpen")]
        closed = with_blinks(np.maximum(measured["EyeBlinkLeft"], measured["EyeBlinkRight"]), blinker, mouth,
                             blink_free(seq.words, T, seq.fps))
        for side in ("Left", "Right"):
            k = ARKIT_NAMES.index(f"EyeBlink{side}")
            weights[:, k] = np.maximum(weights[:, k], closed)
    head = head_rotation(poses, neutral) if T else np.zeros((0, 3))
    return ArkitFace(weights, head, eyes, int(seq.fps))
