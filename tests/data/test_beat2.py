import warnings
import numpy as np
import pytest
import torch

from gesturelsm.motion import MotionSequence
from gesturelsm.data import Beat2Dataset, DatasetError, iter_windows, match_length, window_starts

def test_window_starts():
    assert window_starts(10, 4, 3) == [0, 3, 6]
    assert window_starts(3, 4, 1) == []
    with pytest.raises(ValueError):
        window_starts(10, 0, 1)


def test_match_length_trims_and_pads():
    assert len(match_length(np.ones(20000, np.float32), 30)) == 16000
    padded = match_length(np.ones(100, np.float32), 30)
    assert len(padded) == 16000 and padded[99] == 1 and padded[100] == 0


def test_reader_handles_layout_formats_and_filters(tmp_path, beat2_maker):
    beat2_maker(tmp_path, "2_scott_0_1_1", 90, dtype="float32")
    beat2_maker(tmp_path, "2_scott_0_2_2", 60, sr=44100, dtype="int16", textgrid=False)
    beat2_maker(tmp_path, "4_lawrence_0_1_1", 60)
    (tmp_path / "train_test_split.csv").write_text("id,type\n2_scott_0_1_1,train\n2_scott_0_2_2,test\n"
                                                  "4_lawrence_0_1_1,train\n")
    ds = Beat2Dataset(tmp_path)
    assert ds.names == ["2_scott_0_1_1", "2_scott_0_2_2", "4_lawrence_0_1_1"]
    assert Beat2Dataset(tmp_path, speakers=[2]).names == ["2_scott_0_1_1", "2_scott_0_2_2"]
    assert Beat2Dataset(tmp_path, speakers=["lawrence"]).names == ["4_lawrence_0_1_1"]
    assert Beat2Dataset(tmp_path, split="train", speakers=["scott"]).names == ["2_scott_0_1_1"]

    take = ds.load("2_scott_0_1_1")
    assert take.speaker == 2 and take.split == "train"
    assert len(take.audio) == 90 / 30 * 16000 and take.audio.dtype == np.float32  # trimmed to the motion
    assert [w.text for w in take.words if w.text] == ["hello", "world"]
    take2 = ds.load("2_scott_0_2_2")   # 44.1 kHz int16 -> 16 kHz float in [-1, 1]
    assert take2.words is None          # no TextGrid: text absent, not an error
    assert len(take2.audio) == 60 / 30 * 16000
    assert 0.25 < np.abs(take2.audio).max() <= 1.0


def test_windows_skip_short_takes_with_a_warning_and_cover_the_range(tmp_path, beat2_maker):
    beat2_maker(tmp_path, "2_scott_0_1_1", 100)
    beat2_maker(tmp_path, "2_scott_0_2_2", 20)
    ds = Beat2Dataset(tmp_path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        wins = list(iter_windows(ds, length=32, stride=16, with_audio=True))
    assert any("2_scott_0_2_2" in str(w.message) for w in caught)
    assert [w.start for w in wins] == [0, 16, 32, 48, 64]
    full = ds.features("2_scott_0_1_1")
    assert torch.equal(wins[2].motion, full[32:64])
    assert len(wins[2].audio) == round(32 / 30 * 16000)
    # frame_range picks a fraction of each take (train part = first 80%); the short take's 80% is still too short
    with pytest.warns(UserWarning, match="2_scott_0_2_2: 16 frames in range"):
        train = list(iter_windows(ds, 32, 16, frame_range=(0.0, 0.8)))
    assert max(w.start + 32 for w in train) <= 80


def test_feature_cache_is_invalidated_when_source_changes(tmp_path, beat2_maker):
    beat2_maker(tmp_path, "2_scott_0_1_1", 40)
    ds = Beat2Dataset(tmp_path, cache_dir=tmp_path / "cache")
    a = ds.features("2_scott_0_1_1")
    assert len(list((tmp_path / "cache").glob("*.pt"))) == 1
    assert torch.equal(ds.features("2_scott_0_1_1"), a)  # from cache
    import os

    src = tmp_path / "smplxflame_30" / "2_scott_0_1_1.npz"
    seq = MotionSequence.load(src)
    seq.poses[:] = 0
    before = src.stat().st_mtime_ns
    seq.save(src)
    os.utime(src, ns=(before + 10**9, before + 10**9))     # its mtime a second on, whatever the clock's resolution
    b = ds.features("2_scott_0_1_1")
    assert not torch.equal(a, b)
    assert len(list((tmp_path / "cache").glob("*.pt"))) == 1  # stale entry replaced


def test_unreadable_files_are_named(tmp_path, beat2_maker):
    beat2_maker(tmp_path, "2_scott_0_1_1", 40)
    (tmp_path / "smplxflame_30" / "2_scott_0_9_9.npz").write_bytes(b"garbage")
    ds = Beat2Dataset(tmp_path)
    with pytest.raises(ValueError, match="2_scott_0_9_9.npz"):
        ds.load("2_scott_0_9_9")
    (tmp_path / "wave16k" / "2_scott_0_1_1.wav").write_bytes(b"RIFF0000WAVEjunk")
    with pytest.raises(DatasetError, match="2_scott_0_1_1.wav"):
        ds.load("2_scott_0_1_1")
    with pytest.raises(DatasetError, match="not found"):
        Beat2Dataset(tmp_path / "missing")


def test_real_beat2_folder(beat2_root):
    ds = Beat2Dataset(beat2_root)
    assert ds.names == ["2_scott_0_1_1"]
    assert ds.audio_only_names == ["2_scott_0_2_2", "2_scott_0_3_3"]
    take = ds.load("2_scott_0_1_1")
    assert take.motion.num_frames == 1906
    assert len(take.audio) == round(1906 / 30 * 16000)   # 64.10 s of speech trimmed to 63.53 s of motion
    words = [w.text for w in take.words if w.text]
    assert words[:3] == ["the", "first", "thing"] and len(words) == 199
    only = ds.load("2_scott_0_2_2")
    assert only.motion is None and abs(len(only.audio) / 16000 - 62.0) < 0.1
