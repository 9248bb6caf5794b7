"""The languages a request may name, which recogniser hears each, and which eSpeak NG voice reads its transcripts.

    LANGUAGES["ja"]            # "Japanese"; AUTO ("auto") is the default: English first, other languages when the
                               # English recogniser rejects the speech (transcribe.py)
    espeak_voice("es")         # "es": a typed Spanish transcript is aligned with eSpeak's Spanish voice
    espeak_voice("ja")         # None: eSpeak reads kanji as "Chinese letter" and Chinese with tone numbers, so
                               # Chinese and Japanese words are timed by the recogniser, never by eSpeak

The codes (LANGUAGES, CHOICES) and their eSpeak voices are gesturelsm.align.languages', re-exported here: the aligner
(a floor below) reads typed transcripts with them and `gesturelsm align --language` takes the same codes.
"""
from __future__ import annotations

# The codes and their eSpeak voices live with the aligner (a floor below), which reads typed transcripts with them.
from ..align.languages import AUTO, CHOICES, ENGLISH, LANGUAGES, NO_ESPEAK, espeak_voice, has_cjk

# Languages written without spaces between words: the recogniser gives characters (or short runs) as words.
NO_SPACES = frozenset({"zh", "ja", "yue", "th", "lo", "my", "km", "bo"})


# Chinese and Japanese words come back one character (or short run) each, and the gestures' text features come from
# an English sentence encoder: on eSpeak Japanese the words moved no statistic towards the speaker's and lowered beat
# consistency, so those languages gesture from the audio only (docs/TRANSCRIPTION.md, Other languages).
NOT_FOR_GESTURES = ("the words are shown, not used for the gestures: the text encoder is English and reads Chinese and "
                    "Japanese one character at a time")


def gesture_words(code: str, text: str = "") -> bool:
    """Whether words of `code` (a Whisper code or AUTO, with their `text`) condition the gestures: not for the
    languages written without spaces (NO_SPACES) nor for Han/kana text under AUTO."""
    return code not in NO_SPACES and not (code == AUTO and has_cjk(text))


def name(code: str) -> str:
    return "automatic" if code == AUTO else LANGUAGES.get(code, code)


__all__ = ["AUTO", "CHOICES", "ENGLISH", "LANGUAGES", "NOT_FOR_GESTURES", "NO_ESPEAK", "NO_SPACES", "espeak_voice",
           "gesture_words", "has_cjk", "name"]
