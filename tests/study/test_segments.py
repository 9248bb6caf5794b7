"""`gesturelsm batch --segments CSV`: the study's stimuli cut from each speech's videos to the listed segments."""
from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf

from _support import speech_like
from _study_support import synthetic_video


def _csv(path, rows):
    path.write_text("file_name,start_seconds,end_seconds,duration_seconds\n"
                    + "".join(f"{f},{s},{e},{e - s}\n" for f, s, e in rows))
    return path


@pytest.fixture
def speech(tmp_path):
    d = tmp_path / "speech"
    d.mkdir()
    for k, name in enumerate(("2_scott_0_2_2.wav", "2_scott_0_3_3.wav")):
        sf.write(d / name, speech_like(2.0, seed=k), 16000)
    return d


def test_segments_are_read_by_take_name_and_checked(speech, tmp_path):
    from gesturelsm.errors import InputError
    from gesturelsm.study.segments import check_lengths, read_segments

    files = sorted(speech.iterdir())
    segs = read_segments(_csv(tmp_path / "s.csv", [("2_scott_0_2_2", 0.5, 1.5), ("2_scott_0_3_3.wav", 0, 1)]),
                         files)
    assert segs == {"2_scott_0_2_2.wav": [(0.5, 1.5)], "2_scott_0_3_3.wav": [(0.0, 1.0)]}
    check_lengths(segs, files)
    with pytest.raises(InputError, match="no speech file 'nope'"):
        read_segments(_csv(tmp_path / "b.csv", [("nope", 0, 1)]), files)
    with pytest.raises(InputError, match="0 <= start < end"):
        read_segments(_csv(tmp_path / "c.csv", [("2_scott_0_2_2", 1.5, 0.5)]), files)
    (tmp_path / "d.csv").write_text("name,start\nx,1\n")
    with pytest.raises(InputError, match="needs a header with file_name"):
        read_segments(tmp_path / "d.csv", files)
    with pytest.raises(InputError, match="ends after the speech"):
        check_lengths(read_segments(_csv(tmp_path / "e.csv", [("2_scott_0_2_2", 1, 3)]), files), files)


def test_each_video_is_cut_to_its_segments_with_its_motion(speech, tmp_path):
    import imageio_ffmpeg

    from gesturelsm.study.batch import StudyItem, plan_study
    from gesturelsm.study.segments import cut_segments, read_segments

    files = sorted(speech.iterdir())
    out = tmp_path / "study"
    plan = plan_study(files, ["alpha", "beta"], out, {m: dict(steps=1) for m in ("alpha", "beta")})
    (out / "videos").mkdir(parents=True)
    (out / "key" / "motion").mkdir(parents=True)
    for k, it in enumerate(plan.items):
        audio = sf.read(speech / it.audio, dtype="float32")[0]
        synthetic_video(out / "videos" / it.video, audio, (200, 40, 40), seconds=2.0, fps=30)
        frame = np.arange(60, dtype=np.float32)[:, None] / 100        # each frame's poses name it (f / 100)
        np.savez(out / "key" / "motion" / it.video.replace(".mp4", ".npz"),
                 poses=np.repeat(frame, 165, axis=1) + k, trans=np.zeros((60, 3)))
    segs = read_segments(_csv(tmp_path / "s.csv", [("2_scott_0_2_2", 0.5, 1.5), ("2_scott_0_3_3", 0.2, 1.0),
                                                   ("2_scott_0_3_3", 1.0, 2.0)]), files)
    seg_files, items = cut_segments(plan, files, segs, StudyItem)
    assert [f.name for f in seg_files] == ["2_scott_0_2_2@0.50-1.50.wav", "2_scott_0_3_3@0.20-1.00.wav",
                                           "2_scott_0_3_3@1.00-2.00.wav"]
    assert all(len(sf.read(f)[0]) == pytest.approx(16000 * d, abs=1) for f, d in zip(seg_files, (1.0, 0.8, 1.0)))
    assert len(items) == 6 and len({it.video for it in items}) == 6
    for it in items:
        frames, secs = imageio_ffmpeg.count_frames_and_secs(str(out / "videos" / it.video))
        want = {"2_scott_0_2_2@0.50-1.50.wav": 30, "2_scott_0_3_3@0.20-1.00.wav": 24,
                "2_scott_0_3_3@1.00-2.00.wav": 30}[it.audio]
        assert abs(frames - want) <= 1
        poses = np.load(out / "key" / "motion" / it.video.replace(".mp4", ".npz"))["poses"]
        assert len(poses) == want
    first = next(it for it in items if it.audio.startswith("2_scott_0_2_2") and it.method == "alpha")
    poses = np.load(out / "key" / "motion" / first.video.replace(".mp4", ".npz"))["poses"]
    assert poses[0, 0] == pytest.approx(0.15)               # frame round(30 x 0.5) of the whole motion
    again = cut_segments(plan, files, segs, StudyItem)[1]  # a rerun keeps the names and makes nothing new
    assert [it.video for it in again] == [it.video for it in items]


def test_batch_refuses_bad_segments_before_rendering(tiny_assets, speech, tmp_path, capsys):
    from gesturelsm.cli import main

    bad = _csv(tmp_path / "s.csv", [("2_scott_0_9_9", 0, 1)])
    assert main(["batch", "--audio-dir", str(speech), "--out", str(tmp_path / "o"), "--methods", "gesturelsm",
                 "--design", "rating", "--checkpoints", str(tiny_assets), "--segments", str(bad)]) == 2
    assert "no speech file '2_scott_0_9_9'" in capsys.readouterr().err
    assert not (tmp_path / "o" / "videos").exists()
    assert main(["batch", "--audio-dir", str(speech), "--out", str(tmp_path / "o"), "--segments",
                 str(tmp_path / "missing.csv")]) == 2
    assert "--segments" in capsys.readouterr().err
