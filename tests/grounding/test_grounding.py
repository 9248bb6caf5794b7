"""Grounding a whole SMPL-X motion on the shipped mannequin (grounding/motion.py over solve.py): planted feet stay
put, a sliding foot is pinned, the upper body is bit for bit the input's, contacts blend in and out without pops,
the feet stand on the floor, drift goes; motions that cannot be grounded come back unchanged with a note."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from gesturelsm.evaluation.motion_stats import stats_body
from gesturelsm.grounding import CHANGED_JOINTS, GroundingSettings, ground_motion, rig_of
from gesturelsm.grounding.contacts import segments
from gesturelsm.grounding.rotations import exp, log
from gesturelsm.grounding.targets import TargetParams
from gesturelsm.motion import MotionSequence
from gesturelsm.motion.skeleton import PARENTS
from _support import BEAT2

TAKE = BEAT2 / "smplxflame_30" / "2_scott_0_1_1.npz"
FPS = 30
LEGS = (1, 2, 4, 5, 7, 8)


def standing(seconds: float = 12.0, seed: int = 0) -> MotionSequence:
    """The mannequin standing on y = 0 with its knees a little bent (9 degrees, as people stand), its arms, head
    and face moving (slow random sines)."""
    body = stats_body()
    T = int(seconds * FPS)
    t = np.arange(T)[:, None] / FPS
    rng = np.random.default_rng(seed)
    poses = np.zeros((T, 165))
    upper = [j for j in range(55) if j not in (0, 1, 2, 4, 5, 7, 8, 10, 11)]
    cols = [3 * j + k for j in upper for k in range(3)]
    poses[:, cols] = 0.3 * np.sin(2 * np.pi * rng.uniform(0.2, 1.0, len(cols)) * t + rng.uniform(0, 6, len(cols)))
    poses[:, [3 * 1, 3 * 2]] = -0.075                         # thighs a little forward,
    poses[:, [3 * 4, 3 * 5]] = 0.15                           # knees bent,
    poses[:, [3 * 7, 3 * 8]] = -0.075                         # feet level
    trans = np.tile([0.0, -float(body.rest_vertices()[:, 1].min()), 0.0], (T, 1))
    expr = 0.5 * np.sin(t * rng.uniform(0.5, 2, (1, 100)))
    return MotionSequence(poses, trans, expr)


def sliding_left_foot(seq: MotionSequence, swing: float = 0.12) -> MotionSequence:
    """The left leg swings sideways about the hip by +-`swing` radians, so the left foot slides over the floor
    (0.12: +-10 cm, 16 cm/s at most)."""
    t = np.arange(seq.num_frames) / FPS
    poses = seq.poses.copy()
    poses[:, 3 * 1 + 2] = swing * np.sin(2 * np.pi * 0.25 * t)
    return replace(seq, poses=poses)


def stepping(seq: MotionSequence, side: str = "right", every: float = 2.0, length: float = 0.6,
             offset: float = 0.0) -> MotionSequence:
    """A foot lifts (hip and knee flex, the foot level) and comes down on the same spot every `every` seconds."""
    hip, knee, ankle = {"left": (1, 4, 7), "right": (2, 5, 8)}[side]
    t = np.arange(seq.num_frames) / FPS
    phase = ((t - offset) % every) / length
    bump = np.where((phase < 1) & (t >= offset), np.sin(np.pi * np.clip(phase, 0, 1)) ** 2, 0.0)
    poses = seq.poses.copy()
    poses[:, 3 * hip] += -0.5 * bump                          # the thigh swings forward
    poses[:, 3 * knee] += 1.0 * bump                          # the knee bends
    poses[:, 3 * ankle] += -0.5 * bump                        # the foot stays level: up 10 cm at the top
    return replace(seq, poses=poses)


def joints(seq: MotionSequence) -> np.ndarray:
    return stats_body().joints(seq.poses, seq.trans, betas=seq.betas).astype(np.float64)


def angular_speed(seq: MotionSequence, joint_ids=LEGS) -> np.ndarray:
    """(T-1, J) rad/s of each joint's local rotation."""
    R = exp(seq.poses.reshape(-1, 55, 3)[:, list(joint_ids)].astype(np.float64))
    return np.linalg.norm(log(np.swapaxes(R[:-1], -1, -2) @ R[1:]), axis=-1) * FPS


def assert_pinned(seq: MotionSequence, contacts: np.ndarray, tol: float = 0.01, toes: bool = False,
                  horizontal: bool = False) -> None:
    """Each planted ankle (`toes`: toe joint) stays within `tol` of where its contact began (`horizontal`: seen from
    above, i.e. it does not slide; a heel lifting about the toe joint moves the ankle mostly up)."""
    J = joints(seq)[..., [0, 2] if horizontal else [0, 1, 2]]
    for foot, ankle in ((0, 10), (1, 11)) if toes else ((0, 7), (1, 8)):
        for a, b in segments(contacts[:, foot]):
            moved = np.linalg.norm(J[a:b, ankle] - J[a, ankle], axis=1).max()
            assert moved <= tol, f"foot {foot} moved {100 * moved:.2f} cm during its contact {a}-{b}"


def test_a_sliding_foot_is_pinned_where_it_landed():
    seq = sliding_left_foot(standing())
    before = joints(seq)
    res = ground_motion(seq)
    assert res.note is None and res.contacts[:, 0].mean() > 0.9
    assert_pinned(res.motion, res.contacts)
    after = joints(res.motion)
    c = res.contacts[1:, 0]
    speed = lambda J: np.linalg.norm(np.diff(J[:, 7, [0, 2]], axis=0), axis=1)[c] * FPS   # noqa: E731
    assert speed(before).mean() > 0.05 and speed(after).max() < 0.01


def test_nothing_above_the_pelvis_changes_bit_for_bit():
    seq = stepping(sliding_left_foot(standing(seed=3)))
    seq = replace(seq, trans=seq.trans + np.linspace([0, 0, 0], [1.5, 0.1, -0.8], seq.num_frames))   # drifting
    res = ground_motion(seq)
    assert res.note is None
    keep = [c for j in range(55) if j not in CHANGED_JOINTS for c in range(3 * j, 3 * j + 3)]
    assert np.array_equal(res.motion.poses[:, keep], seq.poses[:, keep])      # pelvis orientation, spine, arms,
    assert np.array_equal(res.motion.expressions, seq.expressions)          # hands, head, jaw, eyes, toes
    assert np.array_equal(res.motion.betas, seq.betas) and res.motion.fps == seq.fps
    assert not np.array_equal(res.motion.poses[:, 3:6], seq.poses[:, 3:6])  # the legs did change
    J0, J1 = joints(seq), joints(res.motion)                                 # the upper body moves rigidly with
    upper = [j for j in range(55) if j not in (0, 1, 2, 4, 5, 7, 8, 10, 11)]    # the root, its shape unchanged
    np.testing.assert_allclose(J1[:, upper] - J1[:, :1], J0[:, upper] - J0[:, :1], atol=1e-5)


def transition_speeds(seq: MotionSequence, blend_frames: int = 8,
                      knee_speed: float = GroundingSettings().knee_speed) -> tuple[np.ndarray, float]:
    """The grounded motion's leg joint angular speeds within the blends around every landing and lift, and the
    input's own 99th percentile of leg joint angular speed."""
    settings = GroundingSettings(targets=TargetParams(blend_frames=blend_frames), knee_speed=knee_speed)
    res = ground_motion(seq, settings=settings)
    changes = [x for f in range(2) for x in np.flatnonzero(np.diff(res.contacts[:, f].astype(int)))]
    assert len(changes) >= 10                                              # the feet lifted again and again
    near = np.zeros(seq.num_frames - 1, bool)
    for x in changes:
        near[max(0, x - 8):x + 8] = True
    return angular_speed(res.motion)[near], float(np.percentile(angular_speed(seq), 99))


def slide_and_step(seconds: float = 18.0) -> MotionSequence:
    """The left foot slides over the floor between its steps (+-5 cm, so each lift leaves a plant behind it) and the
    right foot steps in between."""
    seq = sliding_left_foot(standing(seconds=seconds, seed=5), swing=0.06)
    seq = stepping(seq, "left", every=3.0, length=1.2, offset=1.0)
    return stepping(seq, "right", every=3.0, length=1.2, offset=2.5)


def test_contact_transitions_are_continuous():
    """At every landing and lift (+- the blend), each leg joint turns no faster than the input motion's own 99th
    percentile of joint angular speed; the same motion grounded without blends, or with knees free to straighten
    and bend as fast as the reach asks (a foot put down with the leg nearly straight), pops beyond it (the test can
    fail)."""
    seq = slide_and_step()
    got, bound = transition_speeds(seq)
    assert got.max() <= bound, (got.max(), bound)
    popped, _ = transition_speeds(seq, blend_frames=0, knee_speed=np.inf)
    assert popped.max() > bound
    snapped, _ = transition_speeds(seq, knee_speed=np.inf)
    assert snapped.max() > bound


def test_the_feet_stand_on_the_floor_whether_the_body_floated_or_sank():
    body = stats_body()
    rig = rig_of(standing(1.0), body)
    for lift in (0.12, -0.07):
        seq = sliding_left_foot(standing(seed=2))
        seq = replace(seq, trans=seq.trans + [0.0, lift, 0.0])
        res = ground_motion(seq)
        J = joints(res.motion)
        for foot, ankle in ((0, 7), (1, 8)):
            c = res.contacts[:, foot]
            assert c.mean() > 0.8
            np.testing.assert_allclose(J[c, ankle, 1], rig.ankle_height, atol=2e-3)
        assert J[:, [7, 8], 1].min() >= rig.ankle_height - 2e-3                # nothing sinks
        assert J[:, [10, 11], 1].min() >= rig.toe_height - 2e-3


def test_slow_drift_is_removed_and_the_body_stays_in_a_standing_area():
    seq = standing(seconds=40.0, seed=4)
    walk = np.linspace([0.0, 0.0, 0.0], [2.0, 0.0, -2.0], seq.num_frames)     # 2.8 m away, feet gliding along
    res = ground_motion(replace(seq, trans=seq.trans + walk))
    root = joints(res.motion)[:, 0, [0, 2]]
    assert np.linalg.norm(root[-1] - root[0]) < 0.05
    assert np.linalg.norm(root - root.mean(0), axis=1).max() < 0.5
    assert_pinned(res.motion, res.contacts)


@pytest.mark.parametrize("case", ["one frame", "nan", "inf trans", "sitting", "never still"])
def test_motions_that_cannot_be_grounded_come_back_unchanged_with_a_note(case):
    seq = standing(seconds=4.0)
    if case == "one frame":
        seq, want = seq.slice(0, 1), "1 frame"
    elif case == "nan":
        seq.poses[40, 60] = np.nan
        want = "NaN"
    elif case == "inf trans":
        seq.trans[10, 0] = np.inf
        want = "NaN or infinite"
    elif case == "sitting":
        seq.poses[:, [3, 6]] = -np.pi / 2                                     # thighs forward, level
        seq.poses[:, [12, 15]] = np.pi / 2                                    # shins down
        want = "does not stand"
    else:
        t = np.arange(seq.num_frames) / FPS
        seq.trans[:, 0] += 0.1 * np.sin(2 * np.pi * 3 * t)                  # the whole body shakes at 1.9 m/s
        want = "no foot stays on the ground"
    res = ground_motion(seq)
    assert res.motion is seq and want in res.note and want in res.warning
    assert not res.contacts.any()


def test_a_foot_held_up_for_seconds_stays_up_and_the_other_holds_the_body():
    seq = sliding_left_foot(standing(seconds=10.0, seed=6))
    up = slice(3 * FPS, 8 * FPS)
    seq.poses[up, 3 * 2] = -0.8                                               # right thigh forward ...
    seq.poses[up, 3 * 5] = 1.2                                                # ... knee bent: the foot is up
    res = ground_motion(seq)
    J0, J1 = joints(seq), joints(res.motion)
    inner = slice(up.start + 15, up.stop - 15)
    assert not res.contacts[inner, 1].any() and res.contacts[inner, 0].all()
    np.testing.assert_allclose(J1[inner, 8, 1], J0[inner, 8, 1], atol=0.02)   # still up where it was held
    assert_pinned(res.motion, res.contacts, toes=True)                       # the motion snaps the knee up and
    assert_pinned(res.motion, res.contacts, tol=0.03)                        # down in a frame: the heel peels off
    rest = stats_body().rest_joints()
    for j in range(1, 22):                                                     # no bone stretched or squashed
        bone = np.linalg.norm(J1[:, j] - J1[:, PARENTS[j]], axis=1)
        np.testing.assert_allclose(bone, np.linalg.norm(rest[j] - rest[PARENTS[j]]), atol=1e-5)


def test_the_real_take_keeps_its_feet_planted_and_its_upper_body():
    if not TAKE.exists():
        pytest.skip(f"{TAKE} is absent (the real BEAT2 take lives in ../shared)")
    seq = MotionSequence.load(TAKE)
    res = ground_motion(seq)
    assert res.note is None and res.contacts.mean() > 0.7
    assert_pinned(res.motion, res.contacts, horizontal=True)                 # no foot slides; a heel lifts by
    assert_pinned(res.motion, res.contacts, tol=0.03)                        # 0.3 rad at most (standing straight)
    keep = [c for j in range(55) if j not in CHANGED_JOINTS for c in range(3 * j, 3 * j + 3)]
    assert np.array_equal(res.motion.poses[:, keep], seq.poses[:, keep])
