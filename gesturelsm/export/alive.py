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
* Words (a motion that keeps the words it was made with, `MotionSequence.words`): the mouth's opening alone cannot
  tell a pause, BEAT2's speaker barely closes the jaw between words (JawOpen's median was the same in pauses as in
  words), and words fill ~88 % of a take, so blinks waiting for a closed mouth still landed mid-word 94-100 % of the
  time. With words: (1) `pause_gate` closes the mouth in the pauses, the gaps between words (and before the first,
  after the last) longer than PAUSE_S: the jaw's opening and the mouth's speech shapes (ARKit JawOpen, MouthClose,
  Funnel, Pucker, Stretch, UpperUp, LowerDown; the VRM visemes) are eased to 0 within RAMP_S of the gap's edges,
  never inside a word; (2) a blink that falls due inside a word waits (DEFER_P_WORDS of the time, up to DEFER_S)
  for a pause or a word's border (within BORDER_S of it). Without words (old files, live streams) the face is
  exactly as without this: the mouth as measured, blinks waiting for the mouth to close.
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
PAUSE_S = 0.25           # a gap between words longer than this is a pause: the mouth closes in it
RAMP_S = 0.12            # the mouth eases shut / open over this (or half the pause, when shorter) inside a pause
BORDER_S = 0.10          # a blink may start this close to a word's start or end without counting as mid-word
DEFER_P_WORDS = 0.8      # with words, the share of blinks due mid-word that wait for a pause or a border
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


def _smooth(x: np.ndarray) -> np.ndarray:
    return x * x * (3 - 2 * x)


def _spans(words, seconds: float, merge: bool = True) -> list[tuple[float, float]]:
    """The words' (start, end) in order, overlapping or touching ones merged (`merge`)."""
    out: list[list[float]] = []
    for _, a, b in sorted(words, key=lambda w: (w[1], w[2])):
        a, b = max(0.0, float(a)), min(float(seconds), float(b))
        if b <= a:
            continue
        if merge and out and a <= out[-1][1]:
            out[-1][1] = max(out[-1][1], b)
        else:
            out.append([a, b])
    return [(a, b) for a, b in out]


def pause_gate(words, frames: int, fps: float) -> np.ndarray | None:
    """(frames,) in [0, 1]: 1 inside words and in gaps of PAUSE_S or less, 0 in the pauses (longer gaps, and before
    the first / after the last word), eased over RAMP_S (at most half the pause) inside the pause; None without
    words (the mouth is then left as measured)."""
    if not words or frames <= 0:
        return None
    t = np.arange(frames) / float(fps)
    spans = _spans(words, frames / float(fps))
    if not spans:
        return None
    gate = np.ones(frames)
    edges = [(-np.inf, -np.inf)] + spans + [(np.inf, np.inf)]
    for (_, a), (b, _) in zip(edges[:-1], edges[1:]):       # the gap (a, b) between a word's end and the next's start
        if b - a <= PAUSE_S:
            continue
        ramp = min(RAMP_S, (b - a) / 2.0)
        inside = (t > a) & (t < b)
        down = np.clip((t - a) / ramp, 0.0, 1.0) if np.isfinite(a) else np.ones(frames)
        up = np.clip((b - t) / ramp, 0.0, 1.0) if np.isfinite(b) else np.ones(frames)
        gate[inside] = 1.0 - _smooth(np.minimum(down, up)[inside])
    return gate


def blink_free(words, frames: int, fps: float) -> np.ndarray | None:
    """(frames,) bool: where a blink may start without counting as mid-word: its moment (half shut) outside the
    words or within BORDER_S of a word's start or end (a border between two words counts); None without words."""
    if not words or frames <= 0:
        return None
    t = np.arange(frames) / float(fps)
    free = np.ones(frames, bool)
    t = t + CLOSE_S / 2.0                      # a blink that starts at t is half shut (its moment) at t + CLOSE_S / 2
    for a, b in _spans(words, frames / float(fps), merge=False):
        free &= ~((t > a + BORDER_S) & (t < b - BORDER_S))
    return free


def mid_word(words, onsets_s) -> np.ndarray:
    """Per blink moment (seconds, the eyelid half shut), whether it is mid-word: inside a word and more than BORDER_S
    from its start and end."""
    spans = _spans(words, np.inf, merge=False)
    return np.array([any(a + BORDER_S < x < b - BORDER_S for a, b in spans) for x in onsets_s], bool)


class Blinker:
    """Procedural blinks (module docstring), frame after frame: `next(mouth)` gives the blink weight of as many
    frames as `mouth` (their mouth opening, JAW_FULL scale) has."""

    def __init__(self, fps: int, seed: int = 0) -> None:
        self.fps = int(fps)
        self.rng = np.random.default_rng(seed)
        self.frame = 0
        self.start: int | None = None
        self.due = self._gap(first=True)
        self.draw = float(self.rng.random())        # the blink waits when this is under DEFER_P (DEFER_P_WORDS)

    def _gap(self, first: bool = False) -> int:
        seconds = self.rng.uniform(0.5, MEAN_GAP) if first else \
            MIN_GAP + self.rng.gamma(2.0, (MEAN_GAP - MIN_GAP) / 2.0)
        return self.frame + max(1, int(round(seconds * self.fps)))

    def next(self, mouth: np.ndarray, free: np.ndarray | None = None) -> np.ndarray:
        """`free` (bool per frame, `blink_free`): where the motion's words let a blink start; None (no words): it
        waits for the mouth to close instead."""
        mouth = np.asarray(mouth, np.float64).reshape(-1)
        out = np.zeros(len(mouth))
        for i, m in enumerate(mouth):
            if self.start is None and self.frame >= self.due:
                busy = m > SPEAKING if free is None else not free[i]
                defer = self.draw < (DEFER_P if free is None else DEFER_P_WORDS)
                waiting = defer and busy and (self.frame - self.due) < DEFER_S * self.fps
                if not waiting:
                    self.start = self.frame
            if self.start is not None:
                t = (self.frame - self.start) / self.fps
                out[i] = blink_profile(t)
                if t + 1.0 / self.fps >= BLINK_S:
                    self.start = None
                    self.frame += 1
                    self.due = self._gap()
                    self.draw = float(self.rng.random())
                    continue
            self.frame += 1
        return out


def with_blinks(measured: np.ndarray, blinker: Blinker | None, mouth: np.ndarray,
                free: np.ndarray | None = None) -> np.ndarray:
    """The eyelid closure to export: the model's own when it blinks (closes past MODEL_BLINKS somewhere), else
    its closure with the procedural blinks over it (`free`: Blinker.next's). `blinker` None: the model's as
    measured."""
    measured = np.asarray(measured, np.float64)
    procedural = blinker.next(mouth, free) if blinker is not None else np.zeros(len(measured))
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
    """The VRM visemes (aa ih ou ee oh) measured with the mouth on JAW_FULL's scale (shut in the pauses when the
    motion keeps its words, `pause_gate`), and the blink to export (`with_blinks`): ({preset: (T,)}, (T,))."""
    w = face_weights(body, seq.poses, seq.expressions, seq.betas, wide_open=JAW_FULL)
    words, T = getattr(seq, "words", ()), len(w["blink"])
    gate = pause_gate(words, T, seq.fps)
    if gate is not None:
        w = {k: (v * gate if k in VISEMES else v) for k, v in w.items()}
    mouth = sum(w[v] for v in VISEMES)
    return w, with_blinks(w["blink"], blinker, mouth, blink_free(words, T, seq.fps))


def alive_face_weights(body, seq, blinker: Blinker | None = None) -> dict[str, np.ndarray]:
    """{preset: (T,)} for the VRM visemes and `blink` as exports show them (a VRM / GLB's face, the page's
    character): the mouth on JAW_FULL's scale, blinks from `blinker` (a stream's, carried over its chunks) or a new
    one seeded 0 (module docstring)."""
    w, blink = face_presets(body, seq, blinker if blinker is not None else Blinker(int(seq.fps)))
    return {**w, "blink": blink}
