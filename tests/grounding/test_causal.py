"""Grounding a stream causally, chunk by chunk (grounding/causal.py, grounding/motion_stream.py): however the stream is
cut, the frames are those of the same grounder fed the whole motion at once; a frame once returned depends on no later
frame; a planted foot stays within 1 cm; the upper body is bit for bit the input's; contact transitions are no faster
than the motion's own joints; bad chunks pass through and the stream goes on."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from _standing import (FPS, KEPT_COLUMNS, joints, segments, sliding_left_foot, standing, stepping, swaying)
from gesturelsm.grounding import GroundingSettings, ground_motion
from gesturelsm.grounding.rotations import exp, log
from gesturelsm.grounding.motion_stream import MotionStreamGrounder
from gesturelsm.grounding.targets import TargetParams
from gesturelsm.motion import MotionSequence

CHUNKS = (20, 1, 7, 33, 20, 20, 64, 3, 20)


def streamed(seq: MotionSequence, sizes=CHUNKS) -> tuple[MotionSequence, np.ndarray, list[MotionSequence]]:
    """(the stream grounded chunk by chunk, its contacts, each chunk's output as returned), cycling `sizes`."""
    g = MotionStreamGrounder()
    outs, contacts, a, k = [], [], 0, 0
    while a < seq.num_frames:
        n = sizes[k % len(sizes)]
        res = g.push(seq.slice(a, a + n))
        assert res.note is None and res.motion.num_frames == min(n, seq.num_frames - a)
        outs.append(res.motion)
        contacts.append(res.contacts)
        a, k = a + n, k + 1
    joined = MotionSequence(*(np.concatenate([getattr(m, f) for m in outs]) for f in ("poses", "trans", "expressions")))
    return joined, np.concatenate(contacts), outs


def slide_and_step(seconds: float = 14.0) -> MotionSequence:
    seq = swaying(sliding_left_foot(standing(seconds=seconds, seed=5)))
    seq = stepping(seq, "left", every=3.0, length=1.2, offset=1.0)
    return stepping(seq, "right", every=3.0, length=1.2, offset=2.5)


def test_chunked_equals_the_whole_stream_at_once():
    """The state machines and filters run frame by frame with their state carried, so the cut does not matter: equal
    to the float32 the motion is stored in (the one-pole filters run as lfilter over a chunk, whose sums can round
    differently from one chunk to the next by 1e-16 m)."""
    seq = slide_and_step()
    whole = MotionStreamGrounder().push(seq)
    got, contacts, _ = streamed(seq)
    np.testing.assert_allclose(got.poses, whole.motion.poses, atol=1e-6)
    np.testing.assert_allclose(got.trans, whole.motion.trans, atol=1e-6)
    assert np.array_equal(contacts, whole.contacts) and contacts.any(0).all() and not contacts.all(0).any()
    every, _, _ = streamed(seq, sizes=(1,))                               # one frame at a time
    np.testing.assert_allclose(every.poses, whole.motion.poses, atol=1e-6)


def test_frames_once_returned_never_change_and_need_no_later_frame():
    """Two streams that share their first 200 frames and then go different ways: their first 200 grounded frames are
    the same, and what the grounder returned is not touched by later chunks."""
    a = slide_and_step()
    b = replace(a, poses=a.poses.copy(), trans=a.trans.copy())
    b.trans[200:] += np.linspace([0, 0, 0], [0.8, -0.05, 0.5], a.num_frames - 200).astype(np.float32)
    b.poses[200:, 3:9] *= 0.5
    ga, _, outs = streamed(a)
    gb, _, _ = streamed(b)
    np.testing.assert_array_equal(ga.poses[:200], gb.poses[:200])
    np.testing.assert_array_equal(ga.trans[:200], gb.trans[:200])
    assert not np.allclose(ga.poses[200:], gb.poses[200:])
    again = np.concatenate([m.poses for m in outs])
    np.testing.assert_array_equal(again, ga.poses)                       # the returned arrays, after the stream


def test_a_streamed_sliding_foot_is_planted_within_a_centimetre():
    seq = sliding_left_foot(standing(seconds=12.0, seed=1))
    got, contacts, _ = streamed(seq)
    J0, J = joints(seq), joints(got)
    assert contacts[:, 0].mean() > 0.9
    for foot, ankle in ((0, 7), (1, 8)):
        for a, b in segments(contacts[:, foot]):
            moved = np.linalg.norm(J[a:b, ankle] - J[a, ankle], axis=1).max()
            assert moved <= 0.01, f"foot {foot} moved {100 * moved:.2f} cm during its contact {a}-{b}"
    c = contacts[1:, 0]
    speed = lambda X: np.linalg.norm(np.diff(X[:, 7, [0, 2]], axis=0), axis=1)[c] * FPS   # noqa: E731
    assert speed(J0).mean() > 0.05 and speed(J).max() < 0.005           # it slid at 5+ cm/s before


def test_the_upper_body_is_bit_for_bit_the_input():
    seq = slide_and_step()
    seq = replace(seq, trans=seq.trans + np.linspace([0, 0, 0], [1.5, 0.1, -0.8], seq.num_frames).astype(np.float32))
    got, _, _ = streamed(seq)
    assert np.array_equal(got.poses[:, KEPT_COLUMNS], seq.poses[:, KEPT_COLUMNS])
    assert np.array_equal(got.expressions, seq.expressions)
    assert not np.array_equal(got.poses[:, 3:6], seq.poses[:, 3:6])       # the legs did change
    root = joints(got)[:, 0, [0, 2]]                                        # the walk away is mostly gone
    assert np.linalg.norm(root[-1] - root[0]) < 0.6 < np.linalg.norm(seq.trans[-1, [0, 2]] - seq.trans[0, [0, 2]])


def angular_speed(seq: MotionSequence) -> np.ndarray:
    R = exp(seq.poses.reshape(-1, 55, 3)[:, [1, 2, 4, 5, 7, 8]].astype(np.float64))
    return np.linalg.norm(log(np.swapaxes(R[:-1], -1, -2) @ R[1:]), axis=-1) * FPS


def transition_speeds(seq: MotionSequence, blend_frames: int = 8) -> np.ndarray:
    """The streamed motion's leg joint angular speeds within 10 frames of every landing and lift."""
    settings = GroundingSettings(targets=TargetParams(blend_frames=blend_frames))
    g = MotionStreamGrounder(settings=settings)
    parts = [g.push(seq.slice(a, a + 20)) for a in range(0, seq.num_frames, 20)]
    got = MotionSequence(np.concatenate([p.motion.poses for p in parts]), seq.trans, seq.expressions)
    contacts = np.concatenate([p.contacts for p in parts])
    changes = [x for f in range(2) for x in np.flatnonzero(np.diff(contacts[:, f].astype(int)))]
    assert len(changes) >= 10                                              # the feet lifted again and again
    near = np.zeros(seq.num_frames - 1, bool)
    for x in changes:
        near[max(0, x - 10):x + 10] = True
    return angular_speed(got)[near]


def test_contact_transitions_are_no_faster_than_the_motion_itself():
    """Around every landing and lift each leg joint turns no faster than the input's own 99th percentile of joint
    angular speed (within float32 rounding: where a step's peak falls in a blend the leg is the input's there);
    without the blends it pops well beyond (the test can fail)."""
    seq = slide_and_step(seconds=18.0)
    bound = np.percentile(angular_speed(seq), 99)
    assert transition_speeds(seq).max() <= 1.001 * bound
    assert transition_speeds(seq, blend_frames=0).max() > 1.5 * bound


def test_close_to_the_offline_grounding_on_what_it_is_for():
    """Causal and offline differ (late landings, one-sided filters) but both pin the feet and keep the body near where
    it stood: the streamed feet slide no more than 1 cm/s in contact and the root ends within 10 cm of offline's."""
    seq = slide_and_step()
    got, contacts, _ = streamed(seq)
    off = ground_motion(seq)
    J, Jo = joints(got), joints(off.motion)
    for X, c in ((J, contacts), (Jo, off.contacts)):
        v = np.linalg.norm(np.diff(X[:, [7, 8]][..., [0, 2]], axis=0), axis=-1) * FPS
        assert v[c[1:]].mean() < 0.01
    assert np.abs(J[:, 0] - Jo[:, 0]).max() < 0.1


@pytest.mark.parametrize("bad", ["nan", "inf"])
def test_a_bad_chunk_passes_through_with_a_note_and_the_stream_goes_on(bad):
    seq = sliding_left_foot(standing(seconds=4.0))
    g = MotionStreamGrounder()
    first = g.push(seq.slice(0, 40))
    broken = seq.slice(40, 60)
    broken.poses[5, 30] = np.nan if bad == "nan" else np.inf
    res = g.push(broken)
    assert res.motion is broken and "NaN or infinite" in res.note
    rest = g.push(seq.slice(60, 120))
    assert first.note is None and rest.note is None and np.isfinite(rest.motion.poses).all()
    step = np.linalg.norm(rest.motion.trans[0] - first.motion.trans[-1])
    assert step < 0.01                                                     # no jump across the skipped chunk


def test_a_body_that_does_not_stand_is_passed_through():
    """Sitting (thighs forward, shins down): no foot is planted, so the legs keep their rotations exactly."""
    seq = standing(seconds=3.0)
    seq.poses[:, [3, 6]] = -np.pi / 2
    seq.poses[:, [12, 15]] = np.pi / 2
    got, contacts, _ = streamed(seq)
    assert not contacts.any()
    np.testing.assert_array_equal(got.poses, seq.poses)
