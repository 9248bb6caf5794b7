from dataclasses import dataclass

import numpy as np
import pytest
import torch

from gesturelsm.features.audio import AudioEncoder, audio_channels, envelope, onset_samples
from gesturelsm.features.text import (BLOCK_S, LOOKAHEAD_S, TextEmbedder, WordFeatureStream, features_final_until,
                                      frame_word_index, words_needed)


@dataclass
class W:
    text: str
    start: float
    end: float


def test_envelope_is_the_forward_window_maximum():
    y = np.zeros(5000, np.float32)
    y[3000] = -0.7
    env = envelope(y, 1024)
    assert env[3000] == pytest.approx(0.7) and env[3000 - 1023] == pytest.approx(0.7)   # window [i, i+1024)
    assert env[3000 - 1024] == 0.0 and env[3001] == 0.0
    brute = np.array([np.abs(y[i:i + 1024]).max() for i in range(0, 5000, 97)])
    np.testing.assert_allclose(env[::97], brute)


@pytest.mark.parametrize("n", [0, 1, 5, 1023, 1024, 1025, 4099])
@pytest.mark.parametrize("window", [1, 2, 3, 64, 1024])
def test_envelope_doubling_equals_the_sliding_window_filter(n, window):
    from scipy.ndimage import maximum_filter1d

    y = np.random.default_rng(n).normal(size=n).astype(np.float32)
    ref = maximum_filter1d(np.abs(y), size=window, origin=-(window // 2), mode="constant") if n else np.abs(y)
    np.testing.assert_array_equal(envelope(y, window), ref)


def test_onsets_equal_librosas_detector_on_real_speech(beat2_root):
    """The torch STFT inside `log_mel` must not move a single onset of librosa's own detector."""
    import librosa

    from gesturelsm.data.beat2 import Beat2Dataset

    y = Beat2Dataset(beat2_root).load("2_scott_0_1_1").audio.astype(np.float32)
    ref = librosa.onset.onset_detect(y=y, sr=16000, hop_length=512, units="frames") * 512
    assert len(ref) > 300
    np.testing.assert_array_equal(onset_samples(y), ref)


def test_onsets_land_at_their_sample_positions():
    """Clicks at known times: impulses within one hop (512 samples) of each click, not at frame indices."""
    sr = 16000
    y = np.random.default_rng(0).normal(scale=1e-3, size=sr * 4).astype(np.float32)
    clicks = [8000, 24000, 40000, 56000]
    for c in clicks:
        y[c:c + 800] += np.sin(np.arange(800) / sr * 2 * np.pi * 1000) * np.exp(-np.arange(800) / 200)
    on = onset_samples(y)
    for c in clicks:
        assert np.abs(on - c).min() <= 1024, (c, on)
    ch = audio_channels(y)
    assert ch.shape == (2, len(y)) and set(np.unique(ch[1])) <= {0.0, 1.0}
    assert ch[1].sum() == len(on) and (ch[1][on] == 1).all()
    assert onset_samples(np.zeros(16000, np.float32)).size == 0   # silence: no onsets, no error


@pytest.mark.parametrize("pool", [1, 4])
@pytest.mark.parametrize("frames", [1, 37, 128])
def test_audio_encoder_gives_one_feature_per_frame(pool, frames):
    enc = AudioEncoder((4, 4, 4, 8, 8, 8), pool=pool)
    n = int(round(frames * 16000 / 30))
    out = enc(torch.randn(2, 2, n), frames)
    assert out.shape == (2, frames, 8)


def test_frame_word_index_picks_the_word_spoken_at_each_frame():
    words = [W("", 0.0, 0.5), W("hello", 0.5, 1.0), W("world", 1.0, 1.2)]
    idx = frame_word_index(words, 45)
    assert (idx[:15] == -1).all() and (idx[15:30] == 1).all() and (idx[30:36] == 2).all() and (idx[36:] == -1).all()


def test_text_vectors_are_contextual_and_frames_follow_words():
    emb = TextEmbedder.shared()
    if not emb.available:
        pytest.skip(f"text encoder not installed: {emb.error}")
    a = emb.embed_words("i sat on the river bank".split())
    b = emb.embed_words("i put money in the bank".split())
    assert a.shape == (6, 384)
    cos = float(a[-1] @ b[-1] / np.linalg.norm(a[-1]) / np.linalg.norm(b[-1]))
    assert 0.3 < cos < 0.99          # same word, different context: related but not identical
    long = [f"word{i % 7}" for i in range(600)]   # longer than one chunk: every word gets a vector
    assert (np.linalg.norm(emb.embed_words(long), axis=1) > 0).all()
    ft = emb.frame_features([W("", 0, 0.5), W("hello", 0.5, 1.0)], 30)
    assert not ft.has_word[:15].any() and ft.has_word[15:].all()
    assert (ft.features[:15] == 0).all() and np.allclose(ft.features[15], ft.features[29])


def test_missing_text_model_falls_back_to_audio_only(tmp_path):
    emb = TextEmbedder(model_dir=str(tmp_path / "nowhere"))
    assert not emb.available and "unavailable" in emb.error


@pytest.mark.slow                                    # loads the real text encoder in a new interpreter
def test_loading_the_text_encoder_prints_no_progress_bar():
    """A command that loads the text encoder prints no third-party progress bar (transformers draws one while it
    loads the weights unless told not to)."""
    import subprocess
    import sys
    from pathlib import Path

    code = "from gesturelsm.features.text import TextEmbedder; print(TextEmbedder().available)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600,
                         cwd=Path(__file__).resolve().parents[2])
    if out.stdout.strip() != "True":
        pytest.skip(f"text encoder not installed: {out.stderr.strip()[-200:]}")
    assert "Loading weights" not in out.stderr and "it/s" not in out.stderr and "\r" not in out.stderr


def _spoken(n: int, gap: float = 0.0) -> list:
    """n words of 0.3 s each, `gap` s of silence after every 7th."""
    out, t = [], 0.2
    for i in range(n):
        out.append(W(f"word{i % 11}", t, t + 0.3))
        t += 0.3 + (gap if i % 7 == 6 else 0.0)
    return out


def test_bounded_features_depend_only_on_words_up_to_the_look_ahead():
    emb = TextEmbedder.shared()
    if not emb.available:
        pytest.skip(f"text encoder not installed: {emb.error}")
    words = _spoken(60, gap=0.8)
    T = int(30 * (words[-1].end + 1))
    a = emb.frame_features(words, T)
    cut = 6.0                                          # frames before 6 s ...
    later = [w for w in words if w.start >= words_needed(cut)]
    changed = [w for w in words if w.start < words_needed(cut)] + [W("elephant", w.start, w.end) for w in later]
    b = emb.frame_features(changed, T)                 # ... do not see words from words_needed(6 s) = 10 s on
    n = int(cut * 30)
    assert np.array_equal(a.features[:n], b.features[:n]) and np.array_equal(a.has_word, b.has_word)
    assert not np.array_equal(a.features[n:], b.features[n:])
    assert words_needed(cut) <= cut + BLOCK_S + LOOKAHEAD_S
    whole = emb.frame_features(words, T, context="whole")   # the earlier encoding: related, not equal
    assert np.array_equal(whole.has_word, a.has_word) and not np.array_equal(whole.features, a.features)


def test_word_feature_stream_equals_the_one_shot_features_bit_for_bit():
    emb = TextEmbedder.shared()
    if not emb.available:
        pytest.skip(f"text encoder not installed: {emb.error}")
    words = _spoken(50, gap=1.5)
    T = int(30 * (words[-1].end + 0.5))
    one_shot = emb.frame_features(words, T)
    stream = WordFeatureStream(emb, T)
    seen = 0
    for until in (3.1, 7.9, 8.0, 15.2, 21.0):          # words arrive in pieces, each final up to `until`
        piece = [w for w in words[seen:] if w.start < until]
        seen += len(piece)
        stream.extend(piece, until)
        n = stream.ready_frames()
        assert n == min(T, int(np.ceil(30 * features_final_until(until))))
        assert np.array_equal(stream.features[:n], one_shot.features[:n])
        assert np.array_equal(stream.has_word[:n], one_shot.has_word[:n])
    stream.extend(words[seen:], float("inf"))
    assert stream.ready_frames() == T
    assert np.array_equal(stream.features, one_shot.features) and np.array_equal(stream.has_word, one_shot.has_word)
    with pytest.raises(ValueError, match="context must be one of"):
        emb.frame_features(words, T, context="sometimes")
