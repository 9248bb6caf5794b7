"""The offline driver: a whole take's legs and root grounded at once (`ground_legs`), on any `LegRig`.

1. The root's horizontal path loses its slow drift (drift.py).
2. Each foot's lowest point (ankle or toe, as high above the floor as a level foot's would be) is measured
   against the lower foot, the one the body stands on, and contacts are found from that height and the foot's
   horizontal speed (contacts.py).
3. The root's height follows the planted feet so that they touch the floor (smoothed): by default where the
   straightest planted leg puts it (knees as the motion had them; a leg that cannot reach lifts its heel), with
   `straight=False` where the lowest-reaching one does (lowered where a planted leg could not reach).
4. Each foot's target (targets.py): planted where it landed, level, on the floor; in between, its own path with
   a smoothly varying correction, never below the floor.
5. With `straight`, around landings and lifts a knee straightens and bends no faster than `knee_speed` (the heel
   lifts about the toe joint instead: no snap of a nearly straight knee). Two-bone IK per leg (ik.py): hip and
   knee rotations reach the ankle target, the ankle's rotation turns the foot to its target orientation. Nothing
   else changes: the root's rotation, the spine, arms, head and toes keep their local rotations exactly.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..constants import FPS
from .contacts import ContactParams, detect_contacts
from .drift import DriftParams, remove_drift, smooth
from .ik import REACH, two_bone
from .rig import LegRig, Posed, forward
from .rotations import about, normalize, slerp
from .footsteps import StepParams, plan_steps
from .targets import FootPlan, TargetParams, correction, plan_foot


@dataclass(frozen=True)
class GroundingSettings:
    floor: float = 0.0                                        # m, the floor's height (y)
    contacts: ContactParams = field(default_factory=ContactParams)
    drift: DriftParams | None = field(default_factory=DriftParams)   # None: the horizontal path is kept
    targets: TargetParams = field(default_factory=TargetParams)
    steps: StepParams = field(default_factory=StepParams)
    level: float = 1.0                                        # how much of a planted foot's tilt goes (1: flat)
    height_seconds: float = 0.3                               # smoothing of the root's height correction
    bob: float = 0.6                # the root height's ups and downs are scaled by this (1: as the legs have them)
    reach: float = REACH                                      # a planted leg is stretched at most this much
    knee_seconds: float = 0.2       # smoothing of each leg's hip-to-ankle distance with `straight`
                                    # (else height_seconds)
    straight: bool = True           # True: the root as high as the straightest planted leg asks, knees as the
                                    # motion had them, a heel lifting where a leg cannot reach (False: the lowest)
    heel: float = 0.3               # rad: a planted foot's heel lifts at most this much (the toe joint stays put)
    heel_seconds: float = 0.15      # smoothing of the heel's lift
    knee_speed: float = 2.2         # rad/s: with `straight`, around landings and lifts a knee straightens and bends
                                    # no faster than this (the heel lifts instead)
    min_stance: float = 0.6         # standing: hips above the lower ankle by this share of the leg, in most frames


@dataclass
class Grounded:
    local: np.ndarray               # (T, J, 3, 3) local rotations, the legs' hips, knees and ankles replaced
    root: np.ndarray                # (T, 3) root joint world positions
    contacts: np.ndarray            # (T, 2) bool, left and right foot planted
    note: str | None = None         # why the motion was left as it was (local and root are then the input)

    @property
    def changed(self) -> bool:
        return self.note is None


@dataclass
class Feet:
    """Per frame and foot (left, right): ankle and toe positions (T, 2, 3), the foot's lowest point above the floor
    (T, 2), its horizontal speed (T, 2) and how far its ankle is above a planted ankle's height (T, 2)."""
    ankle: np.ndarray
    toe: np.ndarray
    sole: np.ndarray
    speed: np.ndarray
    excess: np.ndarray


def measure_feet(rig: LegRig, pose: Posed, floor: float, fps: int = FPS) -> Feet:
    ankle = pose.p[:, [leg.ankle for leg in rig.legs]]
    toe = pose.p[:, [leg.toe for leg in rig.legs]]
    excess = ankle[..., 1] - (floor + rig.ankle_height)
    sole = np.minimum(excess, toe[..., 1] - (floor + rig.toe_height))
    mid = (ankle + toe)[..., [0, 2]] / 2
    speed = np.zeros(sole.shape)
    if len(mid) > 1:
        speed = np.linalg.norm(np.gradient(mid, axis=0), axis=-1) * fps
    return Feet(ankle, toe, sole, speed, excess)


def stance_problem(rig: LegRig, pose: Posed, settings: GroundingSettings) -> str | None:
    """Why the pose does not stand on its feet, or None."""
    hips = pose.p[:, [leg.hip for leg in rig.legs], 1].mean(1)
    ankles = pose.p[:, [leg.ankle for leg in rig.legs], 1].min(1)
    leg = np.mean([sum(rig.lengths(leg)) for leg in rig.legs])
    share = np.median((hips - ankles) / leg)
    if share < settings.min_stance:
        return (f"the body does not stand on its feet (its hips are {100 * share:.0f} % of the leg's length above "
                "its ankles, e.g. sitting or kneeling)")
    return None


SOFT_MIN = 0.005                    # m: how soft the minimum over the planted feet is
SOFT_CAP = 0.003                    # m: how softly the smoothed height is kept under the reachable one
SOFT_MAX = 0.001                    # m: how soft the maximum over the planted feet is (the straightest leg)


def leg_lengths(rig: LegRig, pose: Posed, settings: GroundingSettings, fps: int = FPS) -> np.ndarray:
    """(T, 2) how far each leg reaches from hip to ankle: its own stretch over time, smoothed over `height_seconds`
    (the knee noise of a nearly straight leg would otherwise shake the pelvis), never beyond its length."""
    out = np.empty((len(pose.p), len(rig.legs)))
    for f, leg in enumerate(rig.legs):
        d = np.linalg.norm(pose.p[:, leg.ankle] - pose.p[:, leg.hip], axis=-1)
        seconds = settings.knee_seconds if settings.straight else settings.height_seconds
        out[:, f] = np.minimum(smooth(d, seconds, fps), sum(rig.lengths(leg)) * (1 - 1e-6))
    return out


def reachable(rig: LegRig, pose: Posed, plans: list[FootPlan], lengths: np.ndarray, every: bool = True,
              rise: float = 0.0) -> np.ndarray:
    """(T,) the root's height change at which the planted legs reach their plants with `lengths` (T, 2) from hip
    to ankle. `every`: the most it may rise while every planted leg still reaches (a soft minimum over the feet);
    else the height the straightest-held planted leg asks for (a soft maximum: no planted leg then bends its knee
    more than `lengths` has it, the others stretch towards theirs). A foot easing into or out of a plant holds the
    height by as much as it is planted (landing and lifting change it smoothly); interpolated where no foot is
    planted. `rise` (m): the plants' ankles as much higher (a heel lifted off the floor)."""
    T = len(lengths)
    w = np.stack([plan.weight for plan in plans], 1)                       # (T, 2)
    s = np.empty((T, len(plans)))
    for f, (leg, plan) in enumerate(zip(rig.legs, plans)):
        hip, plant = pose.p[:, leg.hip], plan.plant
        dh = np.linalg.norm((plant - hip)[:, [0, 2]], axis=-1)
        s[:, f] = plant[:, 1] + rise - hip[:, 1] + np.sqrt(np.maximum(lengths[:, f] ** 2 - dh ** 2, 0.0))
    if every:
        s = w * s + (1 - w) * s.max(1, keepdims=True)      # a foot lifting lets go of the height gradually
        m = s.min(1)
        dy = m - SOFT_MIN * np.log(np.exp(-(s - m[:, None]) / SOFT_MIN).sum(1))
    else:
        s = w * s + (1 - w) * s.min(1, keepdims=True)
        m = s.max(1)
        dy = m + SOFT_MAX * np.log(np.exp((s - m[:, None]) / SOFT_MAX).mean(1))     # never above the highest
    ok = w.max(1) > 1e-3
    return np.interp(np.arange(T), np.flatnonzero(ok), dy[ok])


def height_shift(rig: LegRig, pose: Posed, plans: list[FootPlan], lengths: np.ndarray, settings: GroundingSettings,
                 fps: int = FPS) -> np.ndarray:
    """(T,) what to add to the root's height: where the planted legs, as they were (`leg_lengths`), put it (so the
    highest planted foot lands with its leg as it was and a lower one bends its knee), smoothed over
    `height_seconds`, its ups and downs around their median scaled by `bob` (the body bobs less: the knees bend a
    little more at the tops and straighten a little at the bottoms), kept softly under where the planted legs reach
    when stretched to `reach`. With `settings.straight`: where the straightest planted leg puts it instead (the
    others stretch, up to `reach` or as far as they were, then lift their heels by up to `heel`), so no knee bends
    more than the motion had it."""
    root = pose.p[:, rig.parents.index(-1), 1]
    natural = root + smooth(reachable(rig, pose, plans, lengths, not settings.straight), settings.height_seconds, fps)
    middle = float(np.median(natural))
    target = middle + settings.bob * (natural - middle) - root
    full = np.array([settings.reach * sum(rig.lengths(leg)) for leg in rig.legs])
    rise = min(heel_rise(rig, leg, settings.heel) for leg in rig.legs) if settings.straight else 0.0
    longest = np.maximum(full, lengths) if settings.straight else np.broadcast_to(full, lengths.shape)
    return soft_min(target, reachable(rig, pose, plans, longest, rise=rise), SOFT_CAP)


def heel_rise(rig: LegRig, leg, angle: float) -> float:
    """How much higher (m) a level foot's ankle is with its heel lifted by `angle` about the toe joint."""
    v = -rig.toe_offset(leg)                                   # toe to ankle
    h, y = float(np.hypot(v[0], v[2])), float(v[1])
    return max(0.0, h * np.sin(angle) + y * np.cos(angle) - y)


def on_toes(rig: LegRig, leg, hip: np.ndarray, ankle: np.ndarray, R: np.ndarray, reach: np.ndarray,
            limit: float, seconds: float = 0.0, fps: int = FPS) -> tuple[np.ndarray, np.ndarray]:
    """The foot's ankle target (T, 3) and world rotation (T, 3, 3) with its heel lifted about the toe joint (which
    stays where it was) as far as needed for the leg to reach it from `hip` (T, 3) with `reach` (T,) from hip to
    ankle, at most `limit` radians, the angle smoothed over `seconds`: a leg held straight lets its foot rise on
    its ball instead of bending the other knee or floating."""
    toe = ankle + (R @ rig.toe_offset(leg))
    v = ankle - toe                                                     # toe to ankle
    up = np.broadcast_to(np.array([0.0, 1.0, 0.0]), v.shape)
    k = normalize(np.cross(v, up))                                      # turning v about k lifts the ankle
    u = np.cross(k, v)
    d = hip - toe
    a, b = (d * v).sum(-1), (d * u).sum(-1)
    C = ((d * d).sum(-1) + (v * v).sum(-1) - reach ** 2) / 2
    r = np.maximum(np.hypot(a, b), 1e-12)
    far = np.linalg.norm(hip - ankle, axis=-1) > reach
    alpha = np.arctan2(b, a) - np.arccos(np.clip(C / r, -1.0, 1.0))
    alpha = np.where(far, np.clip(alpha, 0.0, limit), 0.0)
    alpha = np.clip(smooth(alpha, seconds, fps), 0.0, limit)
    out = toe + v * np.cos(alpha)[:, None] + u * np.sin(alpha)[:, None]
    return out, about(k, alpha) @ R


def unbending(rig: LegRig, leg, hip: np.ndarray, target: np.ndarray, longest: np.ndarray, speed: float,
              slack: float = np.inf, near: np.ndarray | None = None, fps: int = FPS) -> np.ndarray:
    """(T,) how far the leg may reach from `hip` (T, 3) towards its ankle `target` (T, 3) when its knee straightens
    after, and bends before, no faster than `speed` rad/s: the knee angle the target asks for (law of cosines, at
    most `longest` (T,) from hip to ankle), let down no faster than that forward in time and backward in time (so
    only ever bent more than asked), back to a reach. Near straight a
    small change of reach turns the knee fast (a foot put down with the leg nearly straight would snap it); the
    foot then lands on its ball and lowers its heel as the knee unbends (`on_toes`). The reach is never more than
    `slack` (m, what a lifted heel takes up) short of the target's, so a planted foot stays on its plant when the
    motion bends or straightens a knee faster than that allows. `near` (T,) bool: the frames around landings and
    lifts where the limit starts (it holds on until the knee has caught up); None: everywhere."""
    a, b = rig.lengths(leg)
    d = np.minimum(np.linalg.norm(target - hip, axis=-1), longest)
    cos = np.clip((d ** 2 - a * a - b * b) / (2 * a * b), -1.0, 1.0)
    want = np.arccos(cos)                                              # 0: straight
    step = speed / fps
    near = np.ones(len(want), bool) if near is None else near
    got = want.copy()
    held = False
    for t in range(1, len(got)):                                       # straightening after a landing
        if near[t] or held:
            got[t] = max(want[t], got[t - 1] - step)
            held = got[t] > want[t]
    back, held = want.copy(), False
    for t in range(len(got) - 2, -1, -1):                              # bending before a lift (the heel first)
        if near[t] or held:
            back[t] = max(want[t], back[t + 1] - step)
            held = back[t] > want[t]
    got = np.maximum(got, back)
    return np.maximum(np.sqrt(a * a + b * b + 2 * a * b * np.cos(got)), d - slack)


def transitions(contact: np.ndarray, frames: int) -> np.ndarray:
    """(T,) bool: the frames within `frames` of a landing or a lift of a foot's (T,) contact."""
    T = len(contact)
    out = np.zeros(T, bool)
    for x in np.flatnonzero(np.diff(contact.astype(int))):
        out[max(0, x - frames):x + frames + 2] = True
    return out


def soft_min(a: np.ndarray, b: np.ndarray, soft: float) -> np.ndarray:
    """A smooth minimum of two curves: never above either, at most soft * log(2) below the lower."""
    m = np.minimum(a, b)
    return m - soft * np.log(np.exp(-(a - m) / soft) + np.exp(-(b - m) / soft))


def leg_targets(rig: LegRig, feet: Feet, plans: list[FootPlan], settings: GroundingSettings,
                R_ankle: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ankle positions (T, 2, 3) and ankle world rotations (T, 2, 3, 3) the feet go to (targets.py): held by the
    plants, else their own path corrected (easing out of and into the plants, the height rising as the foot's own
    does, lifted at least by the plan's arc when it travels); never so low that the ankle or the toe joint is below
    where a level foot on the floor has them."""
    pos, rot = np.empty_like(feet.ankle), np.empty(feet.ankle.shape + (3,))
    floor = settings.floor
    for f, (leg, plan) in enumerate(zip(rig.legs, plans)):
        orig = feet.ankle[:, f]
        free = orig + correction(orig, plan.contact, plan.plant, settings.targets)
        w = plan.weight[:, None]
        target = free.copy()                                  # height: its own lift, carried by the correction,
        target[:, 1] = np.maximum(target[:, 1], plan.plant[:, 1] + plan.lift)    # at least clearing the floor
        target[:, [0, 2]] = (w * plan.plant + (1 - w) * free)[:, [0, 2]]   # eased out of and into the plants
        R = slerp(R_ankle[:, f], plan.heading, plan.weight)
        toe_y = (R @ rig.toe_offset(leg))[:, 1]
        target[:, 1] = np.maximum(target[:, 1], floor + np.maximum(rig.ankle_height, rig.toe_height - toe_y))
        pos[:, f], rot[:, f] = target, R
    return pos, rot


def ground_legs(rig: LegRig, local: np.ndarray, root: np.ndarray, settings: GroundingSettings = GroundingSettings(),
                fps: int = FPS) -> Grounded:
    """Ground one take: local rotations (T, J, 3, 3) in the rig's convention, root joint world positions (T, 3)."""
    local = np.asarray(local, np.float64)
    root = np.asarray(root, np.float64)
    T = len(root)
    idle = Grounded(local, root, np.zeros((T, 2), bool))
    if T < 2:
        idle.note = f"the motion has {T} frame{'s' if T != 1 else ''}: nothing to ground"
        return idle
    if not (np.isfinite(local).all() and np.isfinite(root).all()):
        idle.note = "the motion contains NaN or infinite values"
        return idle
    root = root.copy()
    if settings.drift is not None:
        root[:, [0, 2]] = remove_drift(root[:, [0, 2]], settings.drift, fps)
    pose = forward(rig, local, root)
    idle.note = stance_problem(rig, pose, settings)
    if idle.note:
        return idle
    feet = measure_feet(rig, pose, settings.floor, fps)
    relative = feet.sole - feet.sole.min(1, keepdims=True)              # above the foot the body stands on
    contacts = detect_contacts(relative, feet.speed, settings.contacts)
    hips = pose.p[:, [leg.hip for leg in rig.legs]][..., [0, 2]]
    contacts = plan_steps(feet.ankle[..., [0, 2]], hips, contacts, settings.steps)
    if not contacts.any():
        idle.note = "no foot stays on the ground long enough to plant it"
        return idle
    R_ankle = pose.R[:, [leg.ankle for leg in rig.legs]]
    heights = (rig.ankle_height, rig.toe_height)
    plans = [plan_foot(feet.ankle[:, f], R_ankle[:, f], contacts[:, f], rig.foot_forward(leg), rig.toe_offset(leg),
                       heights, settings.floor, settings.level, settings.targets) for f, leg in enumerate(rig.legs)]
    lengths = leg_lengths(rig, pose, settings, fps)
    dy = height_shift(rig, pose, plans, lengths, settings, fps)
    root[:, 1] += dy
    pose.p[:, list(rig.chain), 1] += dy[:, None]
    feet = measure_feet(rig, pose, settings.floor, fps)
    pos, rot = leg_targets(rig, feet, plans, settings, R_ankle)
    reaches = None
    if settings.straight:
        reaches = np.empty_like(lengths)
    for f, leg in enumerate(rig.legs if settings.straight else ()):
        longest = np.maximum(settings.reach * sum(rig.lengths(leg)), lengths[:, f])
        longest = np.minimum(longest, unbending(rig, leg, pose.p[:, leg.hip], pos[:, f], longest,
                                                settings.knee_speed, 0.8 * heel_rise(rig, leg, settings.heel),
                                                transitions(plans[f].contact, settings.targets.blend_frames), fps))
        reaches[:, f] = longest
        pos[:, f], rot[:, f] = on_toes(rig, leg, pose.p[:, leg.hip], pos[:, f], rot[:, f], longest,
                                       settings.heel, settings.heel_seconds, fps)
    out = local.copy()
    for f, leg in enumerate(rig.legs):
        sol = two_bone(pose.p[:, leg.hip], pose.p[:, leg.knee], pose.p[:, leg.ankle], pose.R[:, leg.hip],
                       pose.R[:, leg.knee], pos[:, f], np.asarray(rig.knee_axis),
                       settings.reach if reaches is None else 0.0, lengths[:, f] if reaches is None else reaches[:, f])
        parent = pose.R[:, rig.parents[leg.hip]]
        out[:, leg.hip] = np.swapaxes(parent, -1, -2) @ sol.R_hip
        out[:, leg.knee] = np.swapaxes(sol.R_hip, -1, -2) @ sol.R_knee
        out[:, leg.ankle] = np.swapaxes(sol.R_knee, -1, -2) @ rot[:, f]
    return Grounded(out, root, np.stack([plan.contact for plan in plans], 1))


__all__ = ["Feet", "Grounded", "GroundingSettings", "ground_legs", "measure_feet"]
