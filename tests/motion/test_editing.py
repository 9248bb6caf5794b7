"""What an edit asks for: regions and ranges checked against the regions table and the motion's length, the frames
and latents they cover, keyframes and where their poses come from. Bad input is one EditError line each."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.errors import InputError
from gesturelsm.motion.editing import KEY_SPACING, EditError, EditSpec, Keyframe, edit_spec, keyframe
from _support import synthetic_motion

T = 300                      # 10 s


def test_a_range_regenerates_its_frames_and_the_latents_within_one_latent_of_them():
    spec = edit_spec({"upper": [(3.0, 6.0)], "hands": [(3.0, 6.0)]}, T)
    f = spec.frames("upper")
    assert f.sum() == 90 and f[90] and f[179] and not f[89] and not f[180]
    assert not spec.frames("lower").any()
    free = spec.free_latents("upper", 75)
    assert np.flatnonzero(free).tolist() == list(range(21, 46))        # frames 86..183 -> latents 21..45
    assert not spec.free_latents("face", 75).any()
    assert spec.regions == ("upper", "hands")


def test_ranges_of_a_region_are_sorted_and_merged_and_a_bare_pair_is_one_range():
    spec = edit_spec({"face": [(5, 6), (1, 2), (1.5, 3)], "lower": (7, 8)}, T)
    assert spec.ranges["face"] == ((1.0, 3.0), (5.0, 6.0))
    assert spec.ranges["lower"] == ((7.0, 8.0),)
    assert spec.regions == ("lower", "face")                            # the regions table's order
    assert spec.describe() == "lower 7.00-8.00 s; face 1.00-3.00 s, 5.00-6.00 s"


@pytest.mark.parametrize("regenerate, message", [
    ({"arms": [(1, 2)]}, "unknown region 'arms'; the regions are upper, hands, lower, face"),
    ({"upper": [(6, 3)]}, "the range 6-3 s of upper is reversed"),
    ({"upper": [(3, 3)]}, "the range 3-3 s of upper is empty"),
    ({"upper": [(3, 3.01)]}, "is empty: give a range of at least one frame"),
    ({"upper": [(-1, 2)]}, "lies outside the speech (0-10.00 s)"),
    ({"hands": [(8, 12)]}, "the range 8-12 s of hands lies outside the speech"),
    ({"upper": [("a", 2)]}, "is not a (start, end) pair of seconds"),
    ({"upper": [(float("nan"), 2)]}, "is not a number of seconds"),
    ({}, "nothing to regenerate"),
    ({"upper": []}, "nothing to regenerate"),
])
def test_bad_regions_and_ranges_are_one_clear_message(regenerate, message):
    with pytest.raises(EditError, match=None) as err:
        edit_spec(regenerate, T)
    assert message in str(err.value)
    assert isinstance(err.value, InputError) and "\n" not in str(err.value)


def test_a_region_the_method_does_not_generate_is_refused_by_name():
    with pytest.raises(EditError, match="gesturelsm_authors does not generate the face region; it can regenerate "
                                        "upper, hands, lower"):
        edit_spec({"face": [(1, 2)]}, T, regions=("upper", "hands", "lower"), method="gesturelsm_authors")


def test_the_whole_take_can_be_regenerated():
    spec = edit_spec({"lower": [(0, 10)]}, T)
    assert spec.frames("lower").all()


def test_keyframes_need_the_upper_body_regenerated_around_them_and_room_between_them():
    pose = np.zeros(165, np.float32)
    ok = edit_spec({"upper": [(2, 8)]}, T, [Keyframe(5.0, pose), Keyframe(3.0, pose)])
    assert [k.time for k in ok.keyframes] == [3.0, 5.0]                  # sorted
    assert ok.pinned(ok.keyframes[0]) == ("upper",)                     # hands kept there: not pinned
    both = edit_spec({"upper": [(2, 8)], "hands": [(4, 6)]}, T, [Keyframe(5.0, pose)])
    assert both.pinned(both.keyframes[0]) == ("upper", "hands")
    with pytest.raises(EditError, match="needs the upper body regenerated from 0.4 s before it to 0.4 s after"):
        edit_spec({"hands": [(2, 8)]}, T, [Keyframe(5.0, pose)])
    with pytest.raises(EditError, match="needs the upper body regenerated"):
        edit_spec({"upper": [(2, 5.2)]}, T, [Keyframe(5.0, pose)])      # too near the range's end
    with pytest.raises(EditError, match="lies outside the speech"):
        edit_spec({"upper": [(2, 8)]}, T, [Keyframe(11.0, pose)])
    with pytest.raises(EditError, match="closer than 0.4 s"):
        edit_spec({"upper": [(2, 8)]}, T, [Keyframe(5.0, pose), Keyframe(5.0 + (KEY_SPACING - 1) / 30, pose)])


def test_keyframe_poses_come_from_arrays_motions_frames_and_files(tmp_path):
    motion = synthetic_motion(40)
    path = motion.save(tmp_path / "pose.npz")
    assert np.array_equal(keyframe(1.0, f"{path}:7").pose, motion.poses[7])
    assert keyframe(1.0, f"{path}:7").source == "pose.npz:7"
    assert np.array_equal(keyframe(1.0, (motion, 3)).pose, motion.poses[3])
    assert np.array_equal(keyframe(1.0, 5, current=motion).pose, motion.poses[5])      # the motion being edited
    assert np.array_equal(keyframe(1.0, motion.poses[2].reshape(55, 3)).pose, motion.poses[2])
    assert keyframe(2.5, motion.poses[2]).frame == 75


def test_keyframe_sources_that_are_not_poses_are_one_clear_message(tmp_path):
    motion = synthetic_motion(40)
    path = motion.save(tmp_path / "pose.npz")
    (tmp_path / "notes.npz").write_text("not a motion")
    np.save(tmp_path / "array.npy", np.zeros(165))
    cases = [
        (f"{path}:40", "pose.npz has frames 0-39; frame 40 is not one of them"),
        (f"{path}:-1", "frame -1 is not one of them"),
        (str(path), "give a motion file and a frame number as FILE.npz:FRAME"),
        (f"{tmp_path / 'notes.npz'}:0", "keyframe pose: " + str(tmp_path / "notes.npz") + ": not a .npz motion file"),
        (f"{tmp_path / 'array.npy'}:0", "array.npy: one array, not a .npz motion file"),
        (f"{tmp_path / 'missing.npz'}:0", "file not found"),
        (np.zeros(10), "55 joints x 3 axis-angle values"),
        ((motion, 99), "frame 99 is not one of them"),
    ]
    for source, message in cases:
        with pytest.raises(EditError) as err:
            keyframe(1.0, source)
        assert message in str(err.value), (source, str(err.value))
    with pytest.raises(EditError, match="needs the motion it is a frame of"):
        keyframe(1.0, 3)


def test_an_edit_spec_is_frozen():
    spec = edit_spec({"upper": [(1, 2)]}, T)
    assert isinstance(spec, EditSpec)
    with pytest.raises(AttributeError):
        spec.num_frames = 5


def test_ranges_far_outside_the_speech_are_refused_without_overflow():
    """1e308 s passes isfinite; 1e308 * 30 frames is inf: the range is refused in seconds (the page and the API
    call edit_spec too)."""
    for rng in ((0.0, 1e308), (1e308, 1e308 * 1.5), (0.0, float(10**300))):
        with pytest.raises(EditError, match="lies outside the speech|not a number of seconds"):
            edit_spec({"upper": [rng]}, 90)
