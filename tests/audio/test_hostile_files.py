"""Hostile audio uploads: long files are refused before they are decoded, decoding is bounded by
the limit even when the header lies, and nothing but an allow-listed container reaches a decoder."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from gesturelsm.audio import AudioError, AudioTooLongError, load_audio
from gesturelsm.audio.containers import FLAC, MP3, MP4, OGG, WAV, WEBM, probe_duration, sniff_bytes, sniff_container

from _hostile import playlist_naming, silent_flac

REPO = Path(__file__).resolve().parents[2]

# Runs in a fresh interpreter so its peak RSS is this load alone; prints JSON.
_MEASURE = """
import json, sys, time


def peak_mb():
    # VmHWM: this process's own peak resident memory. (ru_maxrss is not: Linux keeps it across fork + exec, so a
    # child of a big pytest process reports the parent's size.)
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return float("nan")


from gesturelsm.audio import AudioError, load_audio
t0 = time.perf_counter()
try:
    load_audio(sys.argv[1], max_seconds=float(sys.argv[2]))
    outcome = "accepted"
except AudioError as exc:
    outcome = f"{type(exc).__name__}: {exc}"
print(json.dumps({"outcome": outcome, "seconds": time.perf_counter() - t0,
                  "peak_mb": peak_mb()}))
"""


def measure_load(path: Path, max_seconds: float = 300) -> dict:
    """Outcome, wall time and peak memory of load_audio(path, max_seconds) in a subprocess."""
    proc = subprocess.run([sys.executable, "-c", _MEASURE, str(path), str(max_seconds)], capture_output=True,
                          text=True, timeout=120, cwd=REPO, env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"})
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize("stated", ["true", "unknown"])
def test_ten_hours_of_silence_are_refused_without_decoding_them(tmp_path, stated):
    """A ~130 KB FLAC of 10 h: decoded in full it is 576 M samples (2.3 GB as float32, more once resampled).
    With the header's length it is refused from the header; with 'unknown length' decoding stops at the limit."""
    flac = silent_flac(tmp_path / "long.flac", 36000, stated_samples=None if stated == "true" else 0)
    assert flac.stat().st_size < 200_000
    got = measure_load(flac)
    assert got["outcome"].startswith("AudioTooLongError"), got
    assert got["peak_mb"] < 500, got         # decoded in full it would need > 2 GB; hangs: the subprocess timeout
                                             # (timings: benchmarks/hostile_uploads.py)


def test_unknown_length_header_still_accepts_audio_within_the_limit(tmp_path):
    flac = silent_flac(tmp_path / "short.flac", 3.0, stated_samples=0)
    assert probe_duration(flac, FLAC) is None
    assert len(load_audio(flac, max_seconds=3.0)) == 48000               # exactly at the limit: accepted
    with pytest.raises(AudioTooLongError, match="longer than the limit"):
        load_audio(flac, max_seconds=2.9)


def test_header_duration_refuses_before_reading(tmp_path):
    flac = silent_flac(tmp_path / "ten.flac", 10.0)
    assert probe_duration(flac, FLAC) == pytest.approx(10.0)
    with pytest.raises(AudioTooLongError, match="10.0 s long; the limit is 5.0 s"):
        load_audio(flac, max_seconds=5)


def test_ffmpeg_decoding_stops_at_the_limit(tmp_path):
    """M4A goes through the bundled ffmpeg: 12 s of audio with a 2 s limit yields at most 2 s + 1 sample."""
    import imageio_ffmpeg

    from gesturelsm.audio.loading import _decode_with_ffmpeg

    m4a = tmp_path / "tone.m4a"
    subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-f", "lavfi", "-i",
                    "sine=frequency=220:sample_rate=16000:duration=12", "-c:a", "aac", str(m4a)], check=True)
    assert sniff_container(m4a) is MP4
    assert probe_duration(m4a, MP4) == pytest.approx(12.0, abs=0.1)
    y, sr = _decode_with_ffmpeg(m4a, 16000, MP4, max_seconds=2.0)
    assert 1.5 * sr < len(y) <= 2 * sr + 1
    with pytest.raises(AudioTooLongError):
        load_audio(m4a, max_seconds=2.0)
    assert len(load_audio(m4a, max_seconds=20.0)) == pytest.approx(12 * 16000, abs=2048)


def test_playlist_naming_a_server_file_is_refused(tmp_path):
    """Before: ffmpeg's HLS demuxer followed the playlist and the server's file became the soundtrack."""
    secret = tmp_path / "secret.flac"
    sf.write(secret, (0.3 * np.sin(np.arange(32000) / 16000 * 2 * np.pi * 200)).astype(np.float32), 16000)
    for name in ("list.m3u8", "list.wav", "list.mp3"):                  # the name does not matter
        with pytest.raises(AudioError, match="playlists and links are not followed"):
            load_audio(playlist_naming(tmp_path / name, secret))


def test_ffconcat_and_text_are_refused(tmp_path):
    concat = tmp_path / "a.wav"
    concat.write_text(f"ffconcat version 1.0\nfile '{tmp_path / 'x.wav'}'\n")
    html = tmp_path / "b.mp3"
    html.write_text("<html><body>not audio</body></html>")
    for p in (concat, html):
        assert sniff_container(p) is None
        with pytest.raises(AudioError, match="not an audio file"):
            load_audio(p)


def test_sniffing_by_content(tmp_path):
    y = (0.1 * np.sin(np.arange(16000) / 16000 * 2 * np.pi * 300)).astype(np.float32)
    for ext, want in (("wav", WAV), ("flac", FLAC), ("ogg", OGG)):
        p = tmp_path / f"x.{ext}"
        sf.write(p, y, 16000)
        renamed = p.rename(tmp_path / f"renamed_{ext}.bin")
        assert sniff_container(renamed) is want
    assert sniff_bytes(b"\x1a\x45\xdf\xa3" + bytes(8)) is WEBM
    assert sniff_bytes(b"ID3\x04\x00\x00\x00\x00\x00\x00") is None          # a tag alone is not audio
    assert sniff_bytes(bytes([0xFF, 0xFB, 0x90, 0x64])) is MP3
    assert sniff_bytes(b"#EXTM3U\n") is None


def test_channel_bomb_is_refused(tmp_path):
    p = tmp_path / "many.wav"
    sf.write(p, np.zeros((1600, 12), np.float32), 16000)
    with pytest.raises(AudioError, match="12 channels"):
        load_audio(p, max_seconds=10)
