"""Offscreen rendering: backend choice, framing, background, poses, tiles, labels (small frames, CPU)."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from gesturelsm.motion import JOINT_NAMES
from gesturelsm.render import (Camera, RenderError, RenderStyle, RenderWarning, fit_camera, render_frames,
                               select_platform)
from gesturelsm.render.backend import choose_backend

BG = (32, 48, 64)
BARE = RenderStyle(size=(128, 128), floor="none", shadow=False, background="#203040")


def body_mask(img: np.ndarray, bg=BG, tol: int = 3) -> np.ndarray:
    return (np.abs(img.astype(int) - np.array(bg)) > tol).any(-1)


def test_backend_is_chosen_and_set():
    import os

    name = select_platform()
    assert name in ("osmesa", "egl")
    assert os.environ["PYOPENGL_PLATFORM"] == name


def test_missing_backends_name_the_libraries():
    def missing():
        raise OSError("cannot open shared object file")

    with pytest.raises(RenderError) as e:
        choose_backend(("osmesa", "egl"), {"osmesa": missing, "egl": missing})
    msg = str(e.value)
    assert "libOSMesa" in msg and "libosmesa6" in msg and "libEGL.so.1" in msg and "libegl1" in msg


def test_body_inside_frame_and_background_as_configured(arms_down, arms_up, body):
    frames = render_frames([arms_down], [0], style=BARE)
    assert frames.shape == (1, 128, 128, 3) and frames.dtype == np.uint8
    img = frames[0]
    m = body_mask(img)
    assert not m[0].any() and not m[-1].any() and not m[:, 0].any() and not m[:, -1].any(), "body touches the border"
    rows = np.nonzero(m.any(1))[0]
    assert rows[-1] - rows[0] > 0.75 * 128, "camera should frame the body closely"
    assert (img[~m] == np.array(BG)).all(), "every non-body pixel is the configured background"
    up = render_frames([arms_up], [0], style=BARE)[0]        # raised hands are inside the frame too
    mu = body_mask(up)
    assert not mu[0].any() and not mu[:, 0].any() and not mu[:, -1].any()
    cam = fit_camera([arms_up], style=BARE)                   # the finger tips are what is highest
    tips = body.joints(arms_up.poses[:1], arms_up.trans[:1])[0, [27, 42]]
    (x0, y0), (x1, y1) = cam.project(tips)
    assert min(y0, y1) < np.nonzero(mu.any(1))[0][0] + 6


def test_different_poses_give_different_pixels(arms_down, make_pose):
    motion = make_pose(2, np.array([-1.2, 0.9]))
    a, b = render_frames([motion], [0, 1], style=BARE)
    changed = body_mask(a) ^ body_mask(b)
    assert changed.mean() > 0.02
    same = render_frames([arms_down], [0, 1], style=BARE)
    assert np.array_equal(same[0], same[1]), "identical poses must render identically (deterministic)"


def test_default_look_has_floor_and_shadow(arms_down):
    st = RenderStyle(size=(128, 128))
    cam = fit_camera([arms_down], style=st)
    lit = render_frames([arms_down], [0], style=st, camera=cam)[0]
    bg = np.round(np.array(st.background) * 255)
    assert np.abs(lit[0, 0].astype(int) - bg).max() <= 2, "the floor fades into the background at the horizon"
    no_floor = render_frames([arms_down], [0], style=RenderStyle(size=(128, 128), floor="none", shadow=False),
                             camera=cam)[0]
    assert np.abs(lit[-20:].astype(int) - no_floor[-20:]).max() > 10, "the floor shows below the body"
    no_shadow = render_frames([arms_down], [0], style=RenderStyle(size=(128, 128), shadow=False), camera=cam)[0]
    d = lit.astype(int).sum(-1) - no_shadow.astype(int).sum(-1)
    assert d.min() < -30 and d.max() <= 3, "the contact shadow only darkens"


def test_jaw_movement_is_visible(make_pose):
    still = make_pose(2, -1.2)
    still.poses[1, 3 * JOINT_NAMES.index("jaw")] = 0.35      # open the mouth ~20 degrees
    a, b = render_frames([still], [0, 1], style=RenderStyle(size=(192, 192), floor="none", shadow=False))
    diff = (np.abs(a.astype(int) - b).max(-1) > 8)
    assert diff.sum() >= 8
    rows = np.nonzero(diff.any(1))[0]
    assert rows.max() < 0.3 * 192, "only the face (top of the frame) changes"


def test_camera_fit_sees_all_points_tightly():
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(500, 3)) * [0.4, 0.5, 0.3] + [0.2, 1.0, -0.3]
    for reserve in (0.0, 0.15):
        cam = Camera.fit(pts, 160, 96, margin=0.05, reserve_top=reserve)
        px = cam.project(pts)
        assert (px[:, 0] > 0).all() and (px[:, 0] < 160).all() and (px[:, 1] > reserve * 96).all() \
            and (px[:, 1] < 96).all()
        u, v = cam.ndc(pts).T
        hi = 1 - 0.05 - 2 * reserve
        tight = [abs(np.abs(u).max() - 0.95), abs(v.max() - hi), abs(v.min() + 0.95)]
        assert min(tight) < 2e-3, f"the fit is not tight: {tight}"
    # the intrinsics agree with project()
    p = cam.to_camera(pts[:5])
    uvw = (cam.intrinsics @ (p * [1, -1, -1]).T).T
    assert np.allclose(uvw[:, :2] / uvw[:, 2:], cam.project(pts[:5]))


def test_side_by_side_tiles_labels_and_padding(make_pose):
    a = make_pose(3, np.array([-1.2, -0.6, 0.0]))
    b = make_pose(5, 1.0)
    st = RenderStyle(size=(96, 96), floor="none", shadow=False, background="#203040")
    with pytest.warns(RenderWarning, match="padded"):
        cam = fit_camera([a, b], style=st)
    with pytest.warns(RenderWarning, match="padded"):
        ab = render_frames([a, b], [0, 4], style=st, camera=cam)
    assert ab.shape == (2, 96, 192, 3)
    aa = render_frames([a, a], [0], style=st, camera=cam)
    assert np.array_equal(ab[0, :, :96], aa[0, :, :96]), "a tile shows its own body only"
    assert not np.array_equal(ab[0, :, 96:], aa[0, :, 96:])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        last = render_frames([a], [2], style=st, camera=cam)[0]
    assert np.array_equal(ab[1, :, :96], last), "the shorter motion holds its last frame"
    with pytest.warns(RenderWarning):
        labelled = render_frames([a, b], [0], style=st, camera=cam, labels=["GestureLSM 8 steps", "GT"],
                                 gen_seconds=[0.42, None])[0]
    changed = np.abs(labelled.astype(int) - ab[0]).max(-1) > 0
    ys, xs = np.nonzero(changed)
    assert changed.any() and ys.max() < 40, "labels are drawn at the top"
    assert xs.min() < 96 and xs.max() >= 96, "each tile has its label"


def test_labels_reserve_space_above_bodies(arms_up):
    st = RenderStyle(size=(128, 128), floor="none", shadow=False, background="#203040")
    with_label = render_frames([arms_up], [0], style=st, labels=["a long label for the method"],
                               gen_seconds=[1.5])[0]
    plain = render_frames([arms_up], [0], style=st)[0]
    top_body = np.nonzero(body_mask(plain).any(1))[0][0]
    # the label box area contains no body pixels: the framing moved the body down
    assert np.nonzero(body_mask(with_label)[:, 64:].any(1))[0][0] > top_body


def test_supersampling_antialiases_the_same_picture(arms_down):
    from dataclasses import replace

    cam = fit_camera([arms_down], style=BARE)
    a = render_frames([arms_down], [0], style=BARE, camera=cam)[0].astype(int)
    b = render_frames([arms_down], [0], style=replace(BARE, supersample=2), camera=cam)[0].astype(int)
    assert a.shape == b.shape and np.abs(a - b).mean() < 3
    big = render_frames([arms_down], [0], style=replace(BARE, size=(256, 256)), camera=cam.resized(256, 256))[0]
    box = big.reshape(128, 2, 128, 2, 3).mean((1, 3))
    err = np.abs(np.round(box) - b)                           # llvmpipe may differ by 1 level in a few pixels
    assert err.max() <= 1 and (err > 0).mean() < 0.01, "= the 2x render averaged over 2 x 2 pixels"
    assert ((b != a).any(-1) & (b != np.array(BG)).any(-1)).sum() > 50, "silhouette pixels get blended"


def test_bad_inputs(make_pose):
    with pytest.raises(ValueError, match="even"):
        RenderStyle(size=(101, 100))
    with pytest.raises(ValueError, match="labels"):
        render_frames([make_pose(2, 0.0)], [0], style=BARE, labels=["a", "b"])
    with pytest.raises(ValueError, match="frame indices"):
        render_frames([make_pose(2, 0.0)], [5], style=BARE)


def test_real_beat2_frame(real_motion):
    frames = render_frames([real_motion], [0, 900], style=BARE)
    m0, m1 = body_mask(frames[0]), body_mask(frames[1])
    for m in (m0, m1):
        assert m.any() and not m[0].any() and not m[-1].any() and not m[:, 0].any() and not m[:, -1].any()
    assert (m0 ^ m1).mean() > 0.01
