"""gesturelsm.audio.loading: any file -> float32 mono at 16 kHz, with human messages for files that cannot be used."""
from __future__ import annotations

import numpy as np
import pytest
import soundfile as sf

from gesturelsm.audio import load_audio, resample, to_mono
from gesturelsm.constants import SAMPLE_RATE
from gesturelsm.errors import AudioError, GestureError


def _dominant_hz(y: np.ndarray, sr: int) -> float:
    spec = np.abs(np.fft.rfft(y * np.hanning(len(y))))
    return float(np.fft.rfftfreq(len(y), 1 / sr)[spec.argmax()])


@pytest.mark.parametrize("sr_in", [8000, 22050, 44100, 48000])
def test_resample_keeps_length_and_pitch(sr_in):
    t = np.arange(int(1.3 * sr_in)) / sr_in
    y = np.sin(2 * np.pi * 440 * t).astype(np.float32)
    out = resample(y, sr_in, SAMPLE_RATE)
    assert out.dtype == np.float32 and len(out) == round(len(y) * SAMPLE_RATE / sr_in)
    assert abs(_dominant_hz(out, SAMPLE_RATE) - 440) < 2


def test_to_mono_scales_integer_pcm_and_averages_channels():
    pcm = np.array([[-32768, 32767], [0, 0], [16384, -16384]], dtype=np.int16)       # (N, C)
    y = to_mono(pcm)
    assert y.shape == (3,) and y.dtype == np.float32
    assert y[1] == pytest.approx(0.0, abs=1e-4) and y[2] == pytest.approx(0.0, abs=1e-4)
    assert to_mono(np.array([-32768], np.int16))[0] == pytest.approx(-1.0, abs=1e-4)
    assert to_mono(np.array([32767], np.int16))[0] == pytest.approx(1.0, abs=1e-4)


def test_load_audio_round_trip_at_another_rate(tmp_path):
    sr = 44100
    y = (0.5 * np.sin(2 * np.pi * 300 * np.arange(sr) / sr)).astype(np.float32)
    sf.write(tmp_path / "s.wav", np.stack([y, y], 1), sr, subtype="PCM_16")               # stereo 16-bit
    out = load_audio(tmp_path / "s.wav")
    assert len(out) == SAMPLE_RATE and abs(_dominant_hz(out, SAMPLE_RATE) - 300) < 2
    assert np.abs(out).max() == pytest.approx(0.5, rel=0.02)


def test_unusable_files_raise_the_error_family(tmp_path):
    with pytest.raises(AudioError, match="not found"):
        load_audio(tmp_path / "missing.wav")
    (tmp_path / "empty.wav").write_bytes(b"")
    with pytest.raises(GestureError, match="empty"):
        load_audio(tmp_path / "empty.wav")
