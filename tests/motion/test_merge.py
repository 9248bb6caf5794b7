"""Merging a regenerated motion into the input: kept values bit for bit, geodesic crossings at range ends within
the speed budget, translation that meets the input at both ends, poses pinned exactly and only nearby."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import torch

from gesturelsm.motion.editing import edit_spec
from gesturelsm.motion.merge import (RAMP_MAX, RAMP_MIN, edit_weights, joint_angles, joint_speeds, merge_edit,
                                     pin_pose, slerp_axis_angle, splice)
from gesturelsm.motion.regions import REGIONS
from gesturelsm.motion.rotations import axis_angle_to_matrix
from _support import synthetic_motion

T = 240


def _pair(seed: int = 1):
    a = synthetic_motion(T, seed=0)
    b = synthetic_motion(T, seed=seed)
    sway = 0.2 * np.sin(np.linspace(0, 3 * np.pi, T))[:, None] * np.array([1.0, 0.1, 0.5])
    b = replace(b, trans=a.trans + np.linspace([0, 0, 0], [0.5, 0.1, -0.3], T) + sway)
    return a, b


def test_slerp_follows_the_geodesic():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(50, 3)), rng.normal(size=(50, 3))
    assert np.allclose(joint_angles(slerp_axis_angle(a, b, np.zeros(50))[:, None], a[:, None]), 0, atol=1e-7)
    assert np.allclose(joint_angles(slerp_axis_angle(a, b, np.ones(50))[:, None], b[:, None]), 0, atol=1e-7)
    mid = slerp_axis_angle(a, b, np.full(50, 0.3))
    whole = joint_angles(a[:, None], b[:, None])[:, 0]
    assert np.allclose(joint_angles(a[:, None], mid[:, None])[:, 0], 0.3 * whole, atol=1e-6)
    assert np.allclose(joint_angles(mid[:, None], b[:, None])[:, 0], 0.7 * whole, atol=1e-6)


def test_untouched_regions_and_frames_outside_the_ranges_are_the_inputs_bits():
    a, b = _pair()
    spec = edit_spec({"upper": [(2.0, 5.0)], "lower": [(3.0, 4.0)]}, T)
    out = merge_edit(a, b, spec)
    pa, po = a.poses.reshape(T, 55, 3), out.poses.reshape(T, 55, 3)
    for name in ("hands", "face", "eyes"):
        j = list(REGIONS[name].joints)
        assert np.array_equal(po[:, j], pa[:, j]), name
    assert np.array_equal(out.expressions, a.expressions)
    up = list(REGIONS["upper"].joints)
    assert np.array_equal(po[:60, up], pa[:60, up]) and np.array_equal(po[150:, up], pa[150:, up])
    assert np.array_equal(out.trans[:90], a.trans[:90]) and np.array_equal(out.trans[120:], a.trans[120:])
    assert np.array_equal(out.betas, a.betas)
    inner = slice(60 + RAMP_MAX, 150 - RAMP_MAX)                       # past the crossings: the regenerated motion
    assert np.array_equal(po[inner, up], b.poses.reshape(T, 55, 3)[inner, up])


def test_crossings_rise_smoothly_and_stay_within_the_speed_budget():
    a, b = _pair()
    spec = edit_spec({"upper": [(2.0, 6.0)]}, T)
    w = edit_weights(a, b, spec, "upper")
    assert (w[:60] == 0).all() and (w[180:] == 0).all() and (w[60:180] > 0).all()
    assert w[60] < 0.1 and w[179] < 0.1 and (w[60 + RAMP_MAX:180 - RAMP_MAX] == 1).all()
    rise = np.diff(w[59:60 + RAMP_MAX + 1])
    assert (rise >= 0).all() and RAMP_MIN <= (w[60:120] < 1).sum() <= RAMP_MAX
    up = list(REGIONS["upper"].joints)
    out = merge_edit(a, b, spec).poses.reshape(T, 55, 3)[:, up]
    pa, pb = a.poses.reshape(T, 55, 3)[:, up], b.poses.reshape(T, 55, 3)[:, up]
    p99 = np.percentile(joint_speeds(pa), 99)
    own = np.maximum(joint_speeds(pa), joint_speeds(pb))                   # what either motion does by itself
    added = joint_speeds(out) - own
    assert added[55:100].max() <= 0.5 * p99 + 1e-6, (added[55:100].max(), p99)
    assert added[140:185].max() <= 0.5 * p99 + 1e-6


def test_a_hard_cut_would_exceed_the_budget_the_crossing_keeps():
    """The oracle the crossing is measured against: switching at the range's frame is a jump many times p99."""
    a, b = _pair()
    up = list(REGIONS["upper"].joints)
    pa, pb = a.poses.reshape(T, 55, 3)[:, up], b.poses.reshape(T, 55, 3)[:, up]
    cut = np.concatenate([pa[:60], pb[60:]])
    assert joint_speeds(cut)[59].max() > 3 * np.percentile(joint_speeds(pa), 99)


def test_translation_meets_the_input_at_both_ends_of_the_span():
    a, b = _pair()
    spec = edit_spec({"lower": [(2.0, 6.0)]}, T)
    out = merge_edit(a, b, spec)
    step = np.linalg.norm(np.diff(out.trans, axis=0), axis=1)
    own = np.maximum(np.linalg.norm(np.diff(a.trans, axis=0), axis=1), np.linalg.norm(np.diff(b.trans, axis=0), axis=1))
    assert (step <= own + 0.01).all()                                      # no jump (b drifts 0.6 m and sways)
    assert np.array_equal(out.trans[180:], a.trans[180:])                  # back where the input is afterwards
    assert not np.allclose(out.trans[100:140], a.trans[100:140], atol=1e-3)


def test_splice_puts_a_decoded_span_in_place_for_the_regions_only():
    a, b = _pair()
    part = b.slice(40, 100)
    out = splice(a, part, 40, ("hands", "lower"))
    h, up = list(REGIONS["hands"].joints), list(REGIONS["upper"].joints)
    po = out.poses.reshape(T, 55, 3)
    assert np.array_equal(po[40:100, h], b.poses.reshape(T, 55, 3)[40:100, h])
    assert np.array_equal(po[:, up], a.poses.reshape(T, 55, 3)[:, up])
    assert np.allclose(out.trans[40, [0, 2]], a.trans[40, [0, 2]])         # the span starts where the input is
    assert np.allclose(np.diff(out.trans[40:100], axis=0), np.diff(b.trans[40:100], axis=0), atol=1e-6)


def test_pin_pose_reaches_the_pose_exactly_and_changes_only_its_neighbourhood():
    a = synthetic_motion(T)
    rng = np.random.default_rng(3)
    pose = rng.normal(scale=0.5, size=165).astype(np.float32)
    up = list(REGIONS["upper"].joints)
    out = pin_pose(a, 100, pose, tuple(up), 12)
    po, pa = out.poses.reshape(T, 55, 3), a.poses.reshape(T, 55, 3)
    assert np.array_equal(po[100, up], pose.reshape(55, 3)[up])
    assert np.array_equal(po[:89], pa[:89]) and np.array_equal(po[112:], pa[112:])
    others = [j for j in range(55) if j not in up]
    assert np.array_equal(po[:, others], pa[:, others])
    turn = joint_angles(pa[100:101, up], pose.reshape(1, 55, 3)[:, up]).max()
    added = joint_speeds(po[:, up]) - joint_speeds(pa[:, up])
    assert added.max() <= np.pi / 2 * turn / 12 * 30 + 1e-4             # a raised cosine over 12 frames each side
    R = axis_angle_to_matrix(torch.from_numpy(po[95:106, up].astype(np.float64)))
    assert torch.allclose(R @ R.transpose(-1, -2), torch.eye(3, dtype=torch.float64).expand_as(R), atol=1e-6)
