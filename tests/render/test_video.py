"""mp4 output: one H.264 yuv420p video + one AAC audio stream, right length, in sync, faststart; CLI."""
from __future__ import annotations

import re
import subprocess

import numpy as np
import pytest
import soundfile as sf

from gesturelsm.audio import AudioError
from gesturelsm.cli import main
from gesturelsm.render import RenderStyle, RenderWarning, prepare_audio, render_video

SR = 16000
STYLE = RenderStyle(size=(64, 64), floor="none", shadow=False)


def ffmpeg() -> str:
    import imageio_ffmpeg

    return imageio_ffmpeg.get_ffmpeg_exe()


def probe(path) -> str:
    return subprocess.run([ffmpeg(), "-hide_banner", "-i", str(path)], capture_output=True, text=True).stderr


def decode_audio(path) -> np.ndarray:
    out = subprocess.run([ffmpeg(), "-v", "error", "-i", str(path), "-vn", "-ac", "1", "-ar", str(SR), "-f", "f32le",
                          "-"], capture_output=True, check=True).stdout
    return np.frombuffer(out, np.float32)


def decode_video(path, size) -> np.ndarray:
    import imageio_ffmpeg

    gen = imageio_ffmpeg.read_frames(str(path))
    next(gen)                                                       # metadata
    return np.stack([np.frombuffer(f, np.uint8).reshape(size[1], size[0], 3) for f in gen])


def step_clip(make_pose, frames: int = 45, step: int = 30):
    """Arms down until frame `step`, then raised; audio silent until step / 30 s, then a tone."""
    angle = np.where(np.arange(frames) < step, -1.2, 1.0)
    t = np.arange(int(frames / 30 * SR) + 12000) / SR                 # longer than the motion: gets trimmed
    y = np.where(t >= step / 30, 0.5 * np.sin(2 * np.pi * 440 * t), 0.0).astype(np.float32)
    return make_pose(frames, angle), y


def test_mp4_streams_duration_sync_faststart(tmp_path, make_pose):
    motion, y = step_clip(make_pose)
    seen = []
    with pytest.warns(RenderWarning, match="trimmed"):
        out = render_video([motion], y, tmp_path / "clip.mp4", style=STYLE, progress=lambda f, m: seen.append(f))
    info = probe(out)
    assert len(re.findall(r"Stream #\d+:\d+.*: Video: h264", info)) == 1
    assert len(re.findall(r"Stream #\d+:\d+.*: Audio: aac", info)) == 1
    assert "yuv420p" in info
    data = out.read_bytes()
    assert data.index(b"moov") < data.index(b"mdat"), "+faststart puts the index first"
    video = decode_video(out, (64, 64))
    assert len(video) == 45                                          # length = the motion's
    change = np.abs(np.diff(video.astype(int), axis=0)).mean((1, 2, 3))
    assert int(np.argmax(change)) + 1 == 30, "the pose changes at video frame 30 (t = 1.0 s)"
    audio = decode_audio(out)
    assert abs(len(audio) / SR - 1.5) < 0.07, len(audio) / SR
    onset = np.argmax(np.abs(audio) > 0.1) / SR
    assert abs(onset - 1.0) < 0.01, "audio sample 0 and video frame 0 are both time 0"
    assert seen and seen[-1] == 1.0 and all(a <= b for a, b in zip(seen, seen[1:]))


def test_side_by_side_video_without_audio(tmp_path, make_pose):
    out = render_video([make_pose(6, -1.2), make_pose(6, 1.0), make_pose(6, 0.0)], None, tmp_path / "three.mp4",
                       labels=["GestureLSM", "RF", "GT"], style=STYLE)
    info = probe(out)
    assert "192x64" in info and "Audio" not in info
    assert len(decode_video(out, (192, 64))) == 6


def test_prepare_audio_pads_trims_and_rejects():
    with pytest.warns(RenderWarning, match="padded"):
        y = prepare_audio(np.ones(SR // 4, np.float32), 60)           # 0.25 s for a 2 s motion
    assert len(y) == 2 * SR and y[: SR // 4].min() == 1 and y[SR // 4:].max() == 0
    stereo = np.stack([np.ones(SR), -np.ones(SR)], 1).astype(np.float32)
    assert np.allclose(prepare_audio(stereo, 30), 0.0)               # mono mix
    with pytest.raises(AudioError):
        prepare_audio(np.array([0.0, np.nan]), 30)
    with pytest.raises(AudioError, match="not found"):
        prepare_audio("/nonexistent/speech.wav", 30)


def test_cli_render_and_errors(tmp_path, make_pose, capsys):
    motion, y = step_clip(make_pose, frames=12, step=6)
    npz = motion.save(tmp_path / "m.npz")
    wav = tmp_path / "s.wav"
    sf.write(wav, y[: int(12 / 30 * SR)], SR)
    out = tmp_path / "out.mp4"
    assert main(["render", str(npz), "--audio", str(wav), "--out", str(out), "--size", "64x64", "--quiet"]) == 0
    assert out.exists() and "Audio: aac" in probe(out)
    png = tmp_path / "f.png"
    assert main(["render", str(npz), str(npz), "--out", str(png), "--frame", "3", "--size", "64x64"]) == 0
    import imageio.v3 as iio

    assert iio.imread(png).shape == (64, 128, 3)
    capsys.readouterr()
    assert main(["render", str(npz), "--audio", str(tmp_path / "missing.wav"), "--out", str(out), "--quiet"]) == 2
    assert "not found" in capsys.readouterr().err
    bad = tmp_path / "bad.wav"
    bad.write_bytes(b"not audio at all" * 10)
    assert main(["render", str(npz), "--audio", str(bad), "--out", str(out), "--quiet"]) == 2
    assert "bad.wav" in capsys.readouterr().err
    assert main(["render", str(npz), str(npz), "--labels", "one", "--out", str(out), "--quiet"]) == 2


def test_cli_render_progress_is_whole_lines_when_not_a_terminal(tmp_path, make_pose, capsys):
    """Progress written to a file or a pipe (here captured, not a terminal) comes as whole lines, at most one per
    tenth of the frames, ending at 100 %; no carriage-return redraws."""
    motion, y = step_clip(make_pose, frames=30, step=6)
    npz = motion.save(tmp_path / "m.npz")
    wav = tmp_path / "s.wav"
    sf.write(wav, y[: SR], SR)
    capsys.readouterr()
    assert main(["render", str(npz), "--audio", str(wav), "--out", str(tmp_path / "o.mp4"), "--size", "64x64"]) == 0
    err = capsys.readouterr().err
    assert "\r" not in err
    lines = [ln for ln in err.splitlines() if ln.startswith("[")]          # progress.Line: "[ 40 %] frame 12/30 ..."
    percents = [int(ln[1:4]) for ln in lines]
    assert 2 <= len(lines) <= 11 and percents == sorted(set(percents)) and percents[-1] == 100
    assert all(" frame " in ln for ln in lines)
    assert main(["render", str(npz), "--audio", str(wav), "--out", str(tmp_path / "q.mp4"), "--size", "64x64",
                 "--quiet"]) == 0
    assert "frame" not in capsys.readouterr().err
