"""The eSpeak NG worker: word onsets in the synthetic speech, and failures reported as TTSUnavailable."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.align import tts


def test_word_onsets_increase_inside_the_audio_and_repeat_exactly(espeak):
    words = ["a", "b", "hello", "the", "world", "twenty one", "o'clock"]
    first, second = tts.synthesize(words, ("en-us", "en-us+f3"))
    for syn in (first, second):
        assert syn.sr == 22050 and syn.audio.dtype == np.float32 and 0 < np.abs(syn.audio).max() <= 1
        assert len(syn.starts) == len(words) and (np.diff(syn.starts) > 0).all()
        assert 0 <= syn.starts[0] < 0.1 and syn.starts[-1] < len(syn.audio) / syn.sr - 0.1
    again = tts.synthesize(words, ("en-us", "en-us+f3"))
    np.testing.assert_array_equal(again[1].audio, second.audio)  # a fresh process per call: reproducible


def test_unknown_voices_are_left_out_and_none_left_is_an_error(espeak):
    out = tts.synthesize(["hello"], ("en-us", "xx-nonexistent"))
    assert [s.voice for s in out] == ["en-us"]
    with pytest.raises(tts.TTSUnavailable, match="no voice 'xx-nonexistent'"):
        tts.synthesize(["hello"], ("xx-nonexistent",))


@pytest.mark.parametrize("script, message", [
    ('import json; print(json.dumps({"error": "eSpeak NG is not installed (apt-get install espeak-ng)"}))',
     "apt-get install espeak-ng"),
    ("import sys; sys.stderr.write('Segmentation fault\\n'); sys.exit(139)", "eSpeak NG failed: Segmentation fault"),
])
def test_a_missing_or_crashing_synthesiser_is_reported(tmp_path, monkeypatch, script, message):
    fake = tmp_path / "worker.py"
    fake.write_text(script)
    monkeypatch.setattr(tts, "_WORKER", fake)
    with pytest.raises(tts.TTSUnavailable, match=message):
        tts.synthesize(["hello"])
