"""A face that looks alive where the face leaves us (ARKit CSV, VMC / Live Link streams, VRM / GLB exports): the
mouth on a face capture's scale, procedural blinks, and head / eye angles relative to the speaker's own neutral.
The motion npz stays as generated; all of it is applied on the way out.

* Mouth: BEAT2's speaker opens the jaw little (0.02 rad median, 0.05 rad at its 99th percentile on the take
  2_scott_0_1_1), so measured against a wide-open 0.35 rad the mouth of speech never passed 0.15. The face's
  exports measure the opening against JAW_FULL = 0.12 rad instead (ARKit's JawOpen, MouthClose, Funnel's opening,
  and the VRM visemes' opening `o`): stressed syllables reach 0.3-0.5, as a face capture of speech does, and a
  closed jaw still reads 0.
* Blinks (`Blinker`): when the model's eyelids never close (the mannequin's expressions have no eyelids; an SMPL-X
  file with FLAME's basis may), blinks are added: intervals of MIN_GAP s plus a gamma-distributed rest (mean gap
  MEAN_GAP s: about 17 a minute, irregular), each BLINK_S long (closing in CLOSE_S, shut HOLD_S, opening in the
  rest); a blink that falls due while the mouth is open waits for it to close (a pause, a word's border) up to
  DEFER_S, but only DEFER_P of the time, so some blinks still land mid-word. Seeded: the same take gives the same
  blinks. Chunk by chunk (a live stream) it carries its state over, so blinks cross chunk borders.
* Head / eyes: the angles are relative to the speaker's neutral, the mean orientation of the head (relative to the
  body's heading) and of each eye (relative to the head) over the take 2_scott_0_1_1 (HEAD_NEUTRAL, EYE_NEUTRAL):
  that speaker holds the head 15 degrees down and 12 degrees to the right throughout, and a rig driven by the raw
  angles looks at the floor. The model learnt that speaker, so its motion shares that neutral.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ..retarget.face import VISEMES, face_weights

JAW_FULL = 0.12          # radians of jaw rotation = a fully open mouth in the face's exports
MEAN_GAP, MIN_GAP = 3.5, 1.2    # seconds between blinks: mean, shortest
BLINK_S, CLOSE_S, HOLD_S = 0.30, 0.08, 0.04
DEFER_S, DEFER_P = 0.8, 0.6
SPEAKING = 0.15          # mouth opening (JAW_FULL scale) above which the mouth counts as open
MODEL_BLINKS = 0.5       # a model whose eyelids close past this somewhere blinks by itself
# the speaker's neutral (quaternions x, y, z, w), measured on 2_scott_0_1_1 with arkit.head_rotation / eye_rotations
HEAD_NEUTRAL = Rotation.from_quat([0.13261, -0.10505, 0.02579, 0.98525])
EYE_NEUTRAL = (Rotation.from_quat([0.0003, 0.01655, -0.00517, 0.99985]),     # left eye
               Rotation.from_quat([0.01243, -0.02464, 0.0018, 0.99962]))     # right eye


def blink_profile(t: np.ndarray) -> np.ndarray:
    """Eyelid closure at `t` seconds into a blink: eased shut in CLOSE_S, held HOLD_S, eased open by BLINK_S."""
    t = np.asarray(t, np.float64)
    close = np.clip(t / CLOSE_S, 0.0, 1.0)
    opening = np.clip((t - CLOSE_S - HOLD_S) / (BLINK_S - CLOSE_S - HOLD_S), 0.0, 1.0)
    smooth = lambda x: x * x * (3 - 2 * x)                          # noqa: E731
    w = np.where(t < CLOSE_S + HOLD_S, smooth(close), 1.0 - smooth(opening))
    return np.where((t < 0) | (t >= BLINK_S), 0.0, w)


class Blinker:
    """Procedural blinks (module docstring), frame after frame: `next(mouth)` gives the blink weight of as many
    frames as `mouth` (their mouth opening, JAW_FULL scale) has."""

    def __init__(self, fps: int, seed: int = 0) -> None:
        self.fps = int(fps)
        self.rng = np.random.default_rng(seed)
        self.frame = 0
        self.start: int | None = None
        self.due = self._gap(first=True)
        self.defer = bool(self.rng.random() < DEFER_P)

    def _gap(self, first: bool = False) -> int:
        seconds = self.rng.uniform(0.5, MEAN_GAP) if first else \
            MIN_GAP + self.rng.gamma(2.0, (MEAN_GAP - MIN_GAP) / 2.0)
        return self.frame + max(1, int(round(seconds * self.fps)))

    def next(self, mouth: np.ndarray) -> np.ndarray:
        mouth = np.asarray(mouth, np.float64).reshape(-1)
        out = np.zeros(len(mouth))
        for i, m in enumerate(mouth):
            if self.start is None and self.frame >= self.due:
                waiting = self.defer and m > SPEAKING and (self.frame - self.due) < DEFER_S * self.fps
                if not waiting:
                    self.start = self.frame
            if self.start is not None:
                t = (self.frame - self.start) / self.fps
                out[i] = blink_profile(t)
                if t + 1.0 / self.fps >= BLINK_S:
                    self.start = None
                    self.frame += 1
                    self.due = self._gap()
                    self.defer = bool(self.rng.random() < DEFER_P)
                    continue
            self.frame += 1
        return out


def with_blinks(measured: np.ndarray, blinker: Blinker | None, mouth: np.ndarray) -> np.ndarray:
    """The eyelid closure to export: the model's own when it blinks (closes past MODEL_BLINKS somewhere), else
    its closure with the procedural blinks over it. `blinker` None: the model's as measured."""
    measured = np.asarray(measured, np.float64)
    procedural = blinker.next(mouth) if blinker is not None else np.zeros(len(measured))
    if blinker is None or (len(measured) and measured.max() >= MODEL_BLINKS):
        return measured
    return np.maximum(measured, procedural)


def neutral_head(rot: Rotation) -> Rotation:
    """The head's orientation (relative to the body's heading) relative to the speaker's neutral."""
    return HEAD_NEUTRAL.inv() * rot


def neutral_eye(rot: Rotation, side: int) -> Rotation:
    """An eye's orientation (relative to the head) relative to the speaker's neutral; side 0 left, 1 right."""
    return EYE_NEUTRAL[side].inv() * rot


def face_presets(body, seq, blinker: Blinker | None) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The VRM visemes (aa ih ou ee oh) measured with the mouth on JAW_FULL's scale, and the blink to export
    (`with_blinks`): ({preset: (T,)}, (T,))."""
    w = face_weights(body, seq.poses, seq.expressions, seq.betas, wide_open=JAW_FULL)
    mouth = sum(w[v] for v in VISEMES)
    return w, with_blinks(w["blink"], blinker, mouth)


def alive_face_weights(body, seq, blinker: Blinker | None = None) -> dict[str, np.ndarray]:
    """{preset: (T,)} for the VRM visemes and `blink` as exports show them (a VRM / GLB's face, the page's
    character): the mouth on JAW_FULL's scale, blinks from `blinker` (a stream's, carried over its chunks) or a new
    one seeded 0 (module docstring)."""
    w, blink = face_presets(body, seq, blinker if blinker is not None else Blinker(int(seq.fps)))
    return {**w, "blink": blink}
