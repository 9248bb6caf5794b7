import torch

from gesturelsm.motion import FEATURE_DIM, GENERATED_REGIONS, REGIONS, join_regions, split_regions
from gesturelsm.motion.skeleton import JOINT_NAMES, MIRROR_PERM, PARENTS


def test_regions_match_the_paper_table():
    dims = {n: r.dim for n, r in REGIONS.items()}
    assert dims == {"upper": 78, "hands": 180, "lower": 57, "face": 106, "eyes": 12}
    assert GENERATED_REGIONS == ("upper", "hands", "lower", "face")
    assert REGIONS["upper"].joint_names[0] == "spine1" and REGIONS["upper"].joint_names[-1] == "right_wrist"
    assert REGIONS["hands"].joint_names[0] == "left_index1" and REGIONS["hands"].joint_names[-1] == "right_thumb3"
    assert REGIONS["face"].joint_names == ("jaw",)


def test_regions_partition_the_vector_and_join_inverts_split():
    cols = sorted(c for r in REGIONS.values() for c in r.columns)
    assert cols == list(range(FEATURE_DIM))
    x = torch.randn(2, 7, FEATURE_DIM)
    parts = split_regions(x, tuple(REGIONS))
    assert torch.equal(join_regions(parts), x)  # nothing lost, nothing moved


def test_join_fills_eyes_with_identity_and_refuses_missing_region():
    x = torch.randn(5, FEATURE_DIM)
    out = join_regions(split_regions(x))
    for j in REGIONS["eyes"].joints:
        assert torch.equal(out[:, 6 * j:6 * j + 6], torch.tensor([1.0, 0, 0, 0, 1, 0]).expand(5, 6))
    parts = split_regions(x)
    del parts["hands"]
    try:
        join_regions(parts)
    except KeyError as exc:
        assert "hands" in str(exc)
    else:
        raise AssertionError("a missing generated region must not be dropped silently")


def test_skeleton_tables():
    assert len(JOINT_NAMES) == 55 and JOINT_NAMES[20] == "left_wrist" and JOINT_NAMES[22] == "jaw"
    assert PARENTS[JOINT_NAMES.index("left_index1")] == JOINT_NAMES.index("left_wrist")
    assert JOINT_NAMES[MIRROR_PERM[JOINT_NAMES.index("left_thumb3")]] == "right_thumb3"
    assert MIRROR_PERM[0] == 0 and MIRROR_PERM[22] == 22
