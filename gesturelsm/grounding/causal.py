"""Grounding as the motion comes, chunk by chunk, each frame decided from the frames before it only (live mode, and a
character's live stream): `StreamGrounder` on any `LegRig`. Frames once returned never change, and the output does
not depend on how the stream is cut into chunks (every filter and state machine runs frame by frame with its state
carried over).

What differs from the offline driver (solve.py), which sees the whole take:
- contacts: `ContactDetector`'s causal state, so a landing is seen `frames_on` frames late and a lift `frames_off`
  frames late (offline moves both back to where they began); steps: `StepPlanner`, as offline, a stepping foot
  lifted over the floor by the offline clearance arc for the step's own length (offline also lifts a foot that
  travels between two plants of its own motion: that needs the next plant, which a stream has not seen yet);
- a foot is pinned where it is shown when its landing is seen (so the pin itself does not move it); its height and
  orientation ease onto the floor and level over `blend_frames` after the landing, and the whole foot eases back
  onto its own motion over `blend_frames` after the lift (offline eases in before the landing too);
- drift: `DriftRemover` (one-pole high-pass forward only, the standing area centred where the stream started);
- the root's height and each leg's reach: one-pole low-passes forward only; with no foot planted the height
  correction holds its last value (offline interpolates to the next contact), and goes back to 0 while the body
  does not stand on its feet (per frame: hips above the lower ankle by less than `min_stance` of the leg).
Only the root position and the hips', knees' and ankles' local rotations change, as offline; a leg with no plant
to ease into or out of keeps its input rotations exactly.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..constants import FPS
from .contacts import ContactDetector
from .drift import DriftRemover, OnePole
from .ik import two_bone
from .rig import LegRig, Posed, forward
from .rotations import slerp, yaw_only
from .solve import SOFT_CAP, SOFT_MIN, Grounded, GroundingSettings, measure_feet, soft_min
from .footsteps import StepPlanner


def _ease(x: float) -> float:
    """smoothstep of a scalar (targets.py's, without numpy's per-call cost: it runs per frame and foot)."""
    x = min(max(x, 0.0), 1.0)
    return x * x * (3 - 2 * x)


@dataclass
class FootState:
    """One foot's state across chunks."""
    contact: bool = False
    since: int = 0                          # frames since its last landing (in contact) or lift
    weight: float = 0.0                     # how strongly its plant holds it (0 free .. 1 planted)
    start: float = 0.0                      # the weight when the current contact or lift began
    plant: np.ndarray | None = None         # (3,) the ankle's place while planted
    heading: np.ndarray | None = None       # (3, 3) the ankle's world rotation while planted (level)
    residual: np.ndarray = field(default_factory=lambda: np.zeros(3))   # shown - own ankle when the phase began
    shown: np.ndarray | None = None         # (3,) the last frame's ankle target
    step_frame: int = -1                    # frames into the current step (-1: not stepping)
    step_frames: int = 0                    # how long the current step is in the air
    step_height: float = 0.0                # how high its arc lifts the foot (m)


@dataclass
class ChunkPlan:
    """Per frame and foot of one chunk: weight (T, F), plant (T, F, 3), heading (T, F, 3, 3), pinned (T, F): in
    contact (the horizontal position is the plant's), residual (T, F, 3) fading, lift (T, F) of a step's arc."""
    weight: np.ndarray
    plant: np.ndarray
    heading: np.ndarray
    pinned: np.ndarray
    residual: np.ndarray
    lift: np.ndarray


class StreamGrounder:
    """`push(local, root)` -> that chunk grounded (module docstring). One stream per object."""

    def __init__(self, rig: LegRig, settings: GroundingSettings = GroundingSettings(), fps: int = FPS):
        self.rig, self.settings, self.fps = rig, settings, fps
        F = len(rig.legs)
        self.drift = DriftRemover(settings.drift, fps) if settings.drift is not None else None
        self.detector = ContactDetector(F, settings.contacts)
        self.steps = StepPlanner(F, settings.steps)
        self.reach = [OnePole(settings.height_seconds, fps) for _ in range(F)]
        self.height = OnePole(settings.height_seconds, fps)
        self.held = 0.0                         # the root's height correction while no foot is planted
        self.mid: np.ndarray | None = None      # (F, 2) the last frame's foot midpoints, for speeds
        self.feet = [FootState() for _ in range(F)]
        self.frames = 0
        self.notes: list[str] = []              # why chunks were passed through unchanged

    def push(self, local: np.ndarray, root: np.ndarray) -> Grounded:
        """Local rotations (T, J, 3, 3) in the rig's convention and root joint world positions (T, 3) of the next
        frames -> those frames grounded. A chunk with NaN or infinite values comes back unchanged (with a note)
        and leaves the state as it was."""
        local = np.asarray(local, np.float64)
        root = np.asarray(root, np.float64)
        T, F = len(root), len(self.rig.legs)
        if T == 0:
            return Grounded(local.copy(), root.copy(), np.zeros((0, F), bool))
        if not (np.isfinite(local[:, list(self.rig.chain)]).all() and np.isfinite(root).all()):
            note = "the motion contains NaN or infinite values"
            self.notes.append(note)
            return Grounded(local, root, np.zeros((T, F), bool), note)
        root = root.copy()
        if self.drift is not None:
            root[:, [0, 2]] = self.drift.run(root[:, [0, 2]])
        pose = forward(self.rig, local, root)
        feet = measure_feet(self.rig, pose, self.settings.floor, self.fps)
        mid = (feet.ankle + feet.toe)[..., [0, 2]] / 2
        prev = mid[:1] if self.mid is None else self.mid[None]
        speed = np.linalg.norm(np.diff(np.concatenate([prev, mid]), axis=0), axis=-1) * self.fps
        self.mid = mid[-1].copy()
        standing = self._standing(pose)
        contacts, plan = self._plan(feet, pose, speed, standing)
        lengths = self._lengths(pose)
        dy = self._height(pose, plan, lengths, standing)
        root[:, 1] += dy
        pose.p[:, list(self.rig.chain), 1] += dy[:, None]
        out = self._solve(local, pose, plan, lengths)
        self.frames += T
        return Grounded(out, root, contacts)

    # ---- per frame: contacts, plants, weights ------------------------------------------------------------------
    def _standing(self, pose: Posed) -> np.ndarray:
        rig = self.rig
        hips = pose.p[:, [leg.hip for leg in rig.legs], 1].mean(1)
        ankles = pose.p[:, [leg.ankle for leg in rig.legs], 1].min(1)
        leg = np.mean([sum(rig.lengths(leg)) for leg in rig.legs])
        return (hips - ankles) / leg >= self.settings.min_stance

    def _plan(self, feet, pose: Posed, speed: np.ndarray, standing: np.ndarray) -> tuple[np.ndarray, ChunkPlan]:
        rig, s = self.rig, self.settings
        T, F = speed.shape
        sole = feet.sole - feet.sole.min(1, keepdims=True)
        hips = pose.p[:, [leg.hip for leg in rig.legs]][..., [0, 2]]
        R_ankle = pose.R[:, [leg.ankle for leg in rig.legs]]
        plan = ChunkPlan(np.zeros((T, F)), feet.ankle.copy(), R_ankle.copy(), np.zeros((T, F), bool),
                         np.zeros((T, F, 3)), np.zeros((T, F)))
        contacts = np.zeros((T, F), bool)
        B, fade = s.targets.blend_frames, s.targets.fade_frames
        for t in range(T):
            raw = self.detector.step(sole[t], speed[t]) & standing[t]
            now = self.steps.step(feet.ankle[t][:, [0, 2]], hips[t], raw)
            contacts[t] = now
            for f, (leg, foot) in enumerate(zip(rig.legs, self.feet)):
                own = feet.ankle[t, f]
                if now[f] != foot.contact:                  # a landing or a lift: a new phase starts here
                    shown = own if foot.shown is None else foot.shown
                    foot.contact, foot.since, foot.start = bool(now[f]), 0, foot.weight
                    foot.residual = shown - own
                    if now[f]:
                        self._land(foot, leg, shown, R_ankle[t, f])
                else:
                    foot.since += 1
                x = (foot.since + 1) / (B + 1)
                foot.weight = foot.start + (1 - foot.start) * _ease(x) if foot.contact else \
                    foot.start * (1 - _ease(x))
                plan.lift[t, f] = self._lift(foot, self.steps.busy[f], own)
                r = foot.residual * (1 - _ease((foot.since + 1) / (fade + 1)))
                plan.weight[t, f], plan.pinned[t, f], plan.residual[t, f] = foot.weight, foot.contact, r
                if foot.plant is not None:
                    plan.plant[t, f], plan.heading[t, f] = foot.plant, foot.heading
                target = own + r
                if foot.plant is not None:
                    w = foot.weight
                    if foot.contact:
                        target = np.array([foot.plant[0], w * foot.plant[1] + (1 - w) * target[1], foot.plant[2]])
                    else:
                        target = w * foot.plant + (1 - w) * target
                foot.shown = target
        return contacts, plan

    def _lift(self, foot: FootState, busy: int, own: np.ndarray) -> float:
        """How high a stepping foot is lifted this frame: when `StepPlanner` starts a step (its `busy` frames to go)
        the foot travels from its plant to where its own motion is, over the step's frames, lifted by an arc (sin^2)
        as offline (targets.py `clearance`: a share of the distance, at most `max_clearance`, lower for a quick one)."""
        p = self.settings.targets
        if foot.step_frame < 0 and busy > 0:                 # a step starts
            travel = 0.0 if foot.plant is None else float(np.hypot(*(own - foot.plant)[[0, 2]]))
            foot.step_frame, foot.step_frames = 0, busy + 1
            quick = p.lift_speed * (foot.step_frames + 1) / (self.fps * np.pi)
            foot.step_height = min(p.clearance * travel, p.max_clearance, quick)
        elif 0 <= foot.step_frame < foot.step_frames - 1:
            foot.step_frame += 1
        else:
            foot.step_frame = -1
            return 0.0
        return foot.step_height * float(np.sin(np.pi * (foot.step_frame + 1) / (foot.step_frames + 1))) ** 2

    def _land(self, foot: FootState, leg, shown: np.ndarray, R_ankle: np.ndarray) -> None:
        """A landing: the plant is where the foot is shown, as high as a level foot on the floor needs."""
        rig, s = self.rig, self.settings
        heading = slerp(R_ankle, yaw_only(R_ankle, rig.foot_forward(leg)), float(s.level))
        plant = shown.copy()
        plant[1] = s.floor + max(rig.ankle_height, rig.toe_height - float((heading @ rig.toe_offset(leg))[1]))
        foot.plant, foot.heading = plant, heading

    # ---- the root's height and the legs' reach --------------------------------------------------------------
    def _lengths(self, pose: Posed) -> np.ndarray:
        """(T, F) each leg's hip-to-ankle reach: its own stretch, low-passed forward, never beyond its length."""
        out = np.empty((len(pose.p), len(self.rig.legs)))
        for f, leg in enumerate(self.rig.legs):
            d = np.linalg.norm(pose.p[:, leg.ankle] - pose.p[:, leg.hip], axis=-1)
            out[:, f] = np.minimum(self.reach[f].run(d), sum(self.rig.lengths(leg)) * (1 - 1e-6))
        return out

    def _height(self, pose: Posed, plan: ChunkPlan, lengths: np.ndarray, standing: np.ndarray) -> np.ndarray:
        """(T,) what to add to the root's height: as offline (solve.py `height_shift`), the most that lets every
        planted leg reach its plant, a soft minimum over the feet weighted by how planted each is; while no foot
        is fully planted it eases towards the last fully planted value (0 while not standing); low-passed forward
        and kept (softly) under the reachable height."""
        T, F = plan.weight.shape
        s = np.empty((T, F))
        for f, leg in enumerate(self.rig.legs):
            hip, plant = pose.p[:, leg.hip], plan.plant[:, f]
            dh = np.linalg.norm((plant - hip)[:, [0, 2]], axis=-1)
            s[:, f] = plant[:, 1] - hip[:, 1] + np.sqrt(np.maximum(lengths[:, f] ** 2 - dh ** 2, 0.0))
        w = plan.weight
        s = w * s + (1 - w) * s.max(1, keepdims=True)
        m = s.min(1)
        m = m - SOFT_MIN * np.log(np.exp(-(s - m[:, None]) / SOFT_MIN).sum(1))
        W = w.max(1)
        raw = np.empty(T)
        for t in range(T):
            if W[t] >= 1.0 - 1e-9:
                self.held = float(m[t])
            hold = self.held if standing[t] else 0.0
            raw[t] = W[t] * m[t] + (1 - W[t]) * hold
        return soft_min(self.height.run(raw), raw, SOFT_CAP)

    # ---- the legs -------------------------------------------------------------------------------------------
    def _solve(self, local: np.ndarray, pose: Posed, plan: ChunkPlan, lengths: np.ndarray) -> np.ndarray:
        """The legs' local rotations reaching their targets (two-bone IK), never below the floor; frames where a
        foot has neither a plant to hold it, a residual, a step's lift nor the floor to keep it up keep that leg's
        input rotations."""
        rig, s = self.rig, self.settings
        out = local.copy()
        for f, leg in enumerate(rig.legs):
            own = pose.p[:, leg.ankle]
            w = plan.weight[:, f, None]
            free = own + plan.residual[:, f]
            target = np.where(plan.pinned[:, f, None], plan.plant[:, f], w * plan.plant[:, f] + (1 - w) * free)
            target[:, 1] = np.where(plan.pinned[:, f], w[:, 0] * plan.plant[:, f, 1] + (1 - w[:, 0]) * free[:, 1],
                                    target[:, 1])
            lifted = plan.lift[:, f] > 0                  # a step: at least clearing the floor by its arc
            target[lifted, 1] = np.maximum(target[lifted, 1], plan.plant[lifted, f, 1] + plan.lift[lifted, f])
            R = slerp(pose.R[:, leg.ankle], plan.heading[:, f], plan.weight[:, f])
            toe_y = (R @ rig.toe_offset(leg))[:, 1]
            lowest = s.floor + np.maximum(rig.ankle_height, rig.toe_height - toe_y)
            sinks = target[:, 1] < lowest
            target[:, 1] = np.maximum(target[:, 1], lowest)
            act = (plan.weight[:, f] > 0) | (np.abs(plan.residual[:, f]).max(1) > 0) | (plan.lift[:, f] > 0) | sinks
            if not act.any():
                continue
            i = np.flatnonzero(act)
            sol = two_bone(pose.p[i, leg.hip], pose.p[i, leg.knee], own[i], pose.R[i, leg.hip], pose.R[i, leg.knee],
                           target[i], np.asarray(rig.knee_axis), s.reach, lengths[i, f])
            parent = pose.R[i, rig.parents[leg.hip]]
            out[i, leg.hip] = np.swapaxes(parent, -1, -2) @ sol.R_hip
            out[i, leg.knee] = np.swapaxes(sol.R_hip, -1, -2) @ sol.R_knee
            out[i, leg.ankle] = np.swapaxes(sol.R_knee, -1, -2) @ R[i]
        return out


__all__ = ["StreamGrounder"]
