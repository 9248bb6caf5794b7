"""Other languages: which recogniser hears the speech (the selection rule, with fakes), the multilingual model's
checksum, the language setting on every entry point, and (slow) a real transcription of eSpeak Spanish."""
from __future__ import annotations

import importlib
import math
from types import SimpleNamespace

import numpy as np
import pytest

from gesturelsm.align import AlignConfig, AlignmentResult, Word
from gesturelsm.asr import multilingual
from gesturelsm.asr.languages import AUTO, CHOICES, espeak_voice, gesture_words, has_cjk
from gesturelsm.asr.source import automatic_words, language_said, typed_alignment
from gesturelsm.asr.transcribe import AUDIO_ONLY_NOTE, Transcript, transcribe
from gesturelsm.settings import CLI, PAGE, Asked, checked, settings_problems

from _asr_support import CHINESE, CHINESE_PINYIN, CHINESE_VOICE, SIMPLIFIED, SR, speak, speak_timed

tmod = importlib.import_module("gesturelsm.asr.transcribe")   # the module (the package exports its function)
AUDIO = (0.1 * np.sin(np.arange(3 * SR) * 0.05)).astype(np.float32)
SPANISH = "ayer por la tarde fuimos al mercado con mi hermana y compramos pan fresco manzanas y una botella de leche"


class FakeMultilingual:
    def __init__(self, lang: str, prob: float):
        self.lang, self.prob, self.detected = lang, prob, 0

    def detect_language(self, audio):
        self.detected += 1
        return self.lang, self.prob, [(self.lang, self.prob)]


@pytest.fixture
def calls(monkeypatch):
    """The English model's verdict and the multilingual model are fakes; returns what was asked of them."""
    seen = SimpleNamespace(english=0, other=[], model=FakeMultilingual("ja", 0.9), english_ok=False)

    def english(y, timing, beam_size):
        seen.english += 1
        if seen.english_ok:
            return Transcript([Word("hello", 0.5, 0.9)], "hello", "en", None, "dtw", [], True, 0.8, "hello", {})
        return tmod._rejected("Automatic transcription was rejected: the English speech recogniser is unsure.",
                              "thank you", 0.2, {"not_english": True})

    def recognize(y, beam_size=1, model=None, language="en"):
        seen.other.append(language)
        return [Word("こ", 0.0, 0.6), Word("ん", 0.6, 0.9)], math.log(0.6), {"model": "fake"}

    monkeypatch.setattr(tmod, "_english", english)
    monkeypatch.setattr(tmod, "recognize", recognize)
    monkeypatch.setattr(multilingual, "load_model", lambda: seen.model)
    return seen


def test_english_speech_never_loads_the_multilingual_model(calls):
    calls.english_ok = True
    tr = transcribe(AUDIO)
    assert tr.accepted and tr.language == "en" and calls.other == [] and calls.model.detected == 0


def test_speech_the_english_model_rejects_is_identified_and_transcribed(calls):
    tr = transcribe(AUDIO)
    assert calls.english == 1 and calls.model.detected == 1 and calls.other == ["ja"]
    assert tr.accepted and tr.language == "ja" and tr.language_probability == pytest.approx(0.9)
    assert tr.text == "こん" and tr.timing_method == "whisper"                  # no spaces between Japanese characters
    assert "in Japanese (identified, probability 0.90)" in language_said(tr)


@pytest.mark.parametrize("lang, prob, said", [("en", 0.95, "heard English too"), ("ja", 0.3, "could not tell")])
def test_english_again_or_an_unsure_identification_keeps_the_rejection(calls, lang, prob, said):
    calls.model = FakeMultilingual(lang, prob)
    tr = transcribe(AUDIO)
    assert not tr.accepted and calls.other == [] and said in tr.warnings[0]
    assert tr.warnings[0].endswith(AUDIO_ONLY_NOTE) and tr.warnings[0].count(AUDIO_ONLY_NOTE) == 1


@pytest.mark.parametrize("lang, prob, accepted", [("ja", 0.9, True), ("nn", 0.6, False), ("en", 0.9, False)])
def test_no_words_from_the_english_model_need_a_sure_identification(calls, monkeypatch, lang, prob, accepted):
    monkeypatch.setattr(tmod, "_english", lambda y, t, b: tmod._rejected("No speech was recognised.",
                                                                          details={"no_words": True}))
    calls.model = FakeMultilingual(lang, prob)
    tr = transcribe(AUDIO)
    assert tr.accepted == accepted and calls.model.detected == 1
    assert accepted or tr.warnings[0].startswith("No speech was recognised.")       # the English model's verdict


def test_english_chosen_keeps_the_english_verdict(calls):
    tr = transcribe(AUDIO, language="en")
    assert not tr.accepted and calls.model.detected == 0 and calls.other == []


def test_a_chosen_language_goes_straight_to_the_multilingual_model(calls):
    tr = transcribe(AUDIO, language="ja")
    assert calls.english == 0 and calls.model.detected == 0 and calls.other == ["ja"]
    assert tr.accepted and tr.language == "ja" and tr.language_probability is None
    assert "(chosen)" in language_said(tr)


def test_remembered_words_are_per_language(calls):
    y = AUDIO + 1e-3
    a, b = automatic_words(y, language="ja"), automatic_words(y, language="ja")
    automatic_words(y, language="zh")
    assert calls.other == ["ja", "zh"] and a.words == b.words and "in Japanese" in a.text_mode


def test_chinese_and_japanese_words_are_shown_not_used_for_the_gestures(calls):
    got = automatic_words(AUDIO + 2e-3, language="ja")
    assert got.words is None and got.transcript.accepted and got.transcript.words       # recognised, kept, not used
    assert got.text_mode.startswith("audio-only (2 words recognised in Japanese (chosen)") and '"こん"' in got.text_mode
    assert "not used for the gestures" in got.text_mode
    assert gesture_words("es") and gesture_words(AUTO, "hola") and not gesture_words(AUTO, "你好")
    assert not gesture_words("zh") and not gesture_words("ja")


def test_unknown_language_is_refused():
    with pytest.raises(ValueError, match="language must be one of"):
        transcribe(AUDIO, language="klingon")
    settings, problems = settings_problems(Asked(language="klingon"), ["gesturelsm"], names=CLI)
    assert settings is None and problems == ["--language must be auto or a language code such as en, ja, zh, es, de, "
                                             "fr (got 'klingon'; the list: gesturelsm transcribe --help)."]
    assert checked(Asked(language=" JA "), ["gesturelsm"], names=PAGE).language == "ja"
    assert checked(Asked(), ["gesturelsm"]).language == AUTO and "zh" in CHOICES


def test_typed_transcripts_take_their_language_voice():
    assert typed_alignment(AUTO, "hello there") == AlignConfig()                 # English as before
    assert typed_alignment("es", "hola").voices == ("es+klatt", "es+m7", "es+f3")
    assert typed_alignment("fr", "bonjour").voices[0] == "fr-fr+klatt"
    for lang, text in (("ja", "こんにちは"), ("zh", "你好"), (AUTO, "你好")):
        assert typed_alignment(lang, text).voices == ()                         # eSpeak does not read them
    assert espeak_voice("zh") is None and espeak_voice("de") == "de" and has_cjk("日本") and not has_cjk("día")


def test_recognised_words_start_inside_the_speech():
    y = np.zeros(3 * SR, np.float32)
    y[SR: 2 * SR] = 0.3 * np.sin(np.arange(SR) * 0.2)
    out = tmod.inside_speech([Word("a", 0.0, 1.4), Word("b", 1.4, 1.9)], y)
    assert out[0].start == pytest.approx(1.0, abs=0.05) and out[1].start == 1.4 and out[0].end == 1.4


def test_a_joined_model_file_that_does_not_match_is_refused(tmp_path):
    if not multilingual.available():
        pytest.skip("the multilingual recogniser's wheels are not installed")
    (tmp_path / "model.bin").write_bytes(b"not the model")                    # e.g. a truncated or altered file
    with pytest.raises(multilingual.ModelChecksumError) as err:
        multilingual.joined_dir(tmp_path)
    assert "\n" not in str(err.value) and "delete it" in str(err.value)
    with pytest.raises(multilingual.ModelChecksumError):
        multilingual.joined_dir(tmp_path / "fresh", expected="0" * 64)         # joined afresh, still checked
    assert (tmp_path / "fresh" / "model.bin").stat().st_size == sum(p.stat().st_size
                                                                   for p in multilingual.part_files()[0])


def test_the_cache_folder_is_configurable(monkeypatch, tmp_path):
    monkeypatch.setenv("GESTURELSM_MODEL_CACHE", str(tmp_path))
    assert multilingual.cache_dir() == tmp_path


@pytest.mark.slow
def test_spanish_speech_is_identified_and_timed_inside_the_speech(recognizer, espeak):
    if not multilingual.available():
        pytest.skip("the multilingual recogniser's wheels are not installed")
    y = speak(SPANISH, "es")                                                   # 0.5 s of faint noise each side
    tr = transcribe(y)
    assert tr.accepted and tr.language == "es" and tr.language_probability > 0.5
    starts = np.array([w.start for w in tr.words])
    assert len(tr.words) >= len(SPANISH.split()) - 4 and np.all(np.diff(starts) > 0)
    assert starts[0] >= 0.4 and tr.words[-1].end <= len(y) / SR - 0.3         # inside the speech, not the padding
    assert {"tarde", "hermana"} <= {w.text.strip(",.").lower() for w in tr.words}


@pytest.mark.slow
def test_chinese_speech_is_identified_and_its_characters_timed_by_gesturelsm_transcribe(recognizer, espeak, tmp_path,
                                                                                      capsys):
    """eSpeak's Mandarin (from pinyin, 48 syllables, 14.5 s) through `gesturelsm transcribe`: Chinese identified, the
    characters printed with increasing times inside the speech, each word's start near eSpeak's onset of its
    syllable (matched character by character; measured: 38 of 48 characters, mean 0.06 s off)."""
    import difflib

    import soundfile as sf

    from gesturelsm.cli import main

    if not multilingual.available():
        pytest.skip("the multilingual recogniser's wheels are not installed")
    y, onsets = speak_timed(CHINESE_PINYIN, CHINESE_VOICE)
    wav = tmp_path / "zh.wav"
    sf.write(wav, y, SR)
    assert main(["transcribe", str(wav)]) == 0
    head, text, *lines = capsys.readouterr().out.splitlines()
    assert " in Chinese (identified, probability 0." in head
    words = [(float(a), float(b), w) for a, b, w in (line.split(None, 2) for line in lines)]
    starts = np.array([a for a, _, _ in words])
    assert np.all(np.diff(starts) >= 0) and starts[0] >= 0.4 and words[-1][1] <= len(y) / SR - 0.3
    chars, first = [], []
    for start, _, w in words:
        for i, c in enumerate(c for c in w.translate(SIMPLIFIED) if has_cjk(c)):
            chars.append(c)
            first.append(start if i == 0 else None)
    match = difflib.SequenceMatcher(None, CHINESE, "".join(chars), autojunk=False).get_matching_blocks()
    assert sum(n for *_, n in match) >= 0.6 * len(CHINESE)
    errors = np.abs([first[b + k] - onsets[a + k] for a, b, n in match for k in range(n) if first[b + k] is not None])
    assert len(errors) >= 20 and np.mean(errors) < 0.15 and np.mean(errors < 0.2) >= 0.8


def test_the_pipeline_aligns_typed_text_in_its_language_and_keeps_cjk_text_out_of_the_gestures(tiny_pipeline, espeak,
                                                                                               monkeypatch):
    import gesturelsm.pipeline as pipeline

    used = []
    monkeypatch.setattr(pipeline, "align_words", lambda y, text, config: used.append(config.voices) or
                        AlignmentResult([Word("hola", 0.2, 0.6)], 0.9, "dtw"))
    y = speak("hola amigos", "es")
    es = tiny_pipeline.prepare_speech(y, SR, text="hola amigos", language="es", transcribe=False)
    assert used == [("es+klatt", "es+m7", "es+f3")] and es.words and es.has_word.any()
    for lang in ("zh", AUTO):
        zh = tiny_pipeline.prepare_speech(y, SR, text="你好世界", language=lang, transcribe=False)
        assert zh.words is None and not zh.has_word.any() and "not used for the gestures" in zh.text_mode
    assert len(used) == 1


def test_a_web_request_carries_its_language_to_the_settings():
    from gesturelsm.serve.checks import check_request
    from gesturelsm.serve.request import Request
    from gesturelsm.settings import Limits

    _, settings, problems = check_request(Request("a.wav", language="es"), ["gesturelsm"], Limits(), [256, 384, 512])
    assert problems == [] and settings.language == "es"
    _, settings, problems = check_request(Request("a.wav", language="xx"), ["gesturelsm"], Limits(), [256, 384, 512])
    assert settings is None and problems[0].startswith("Language must be auto or a language code")
