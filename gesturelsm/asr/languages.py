"""The languages a request may name, which recogniser hears each, and which eSpeak NG voice reads its transcripts.

    LANGUAGES["ja"]            # "Japanese"; AUTO ("auto") is the default: English first, other languages when the
                               # English recogniser rejects the speech (transcribe.py)
    espeak_voice("es")         # "es": a typed Spanish transcript is aligned with eSpeak's Spanish voice
    espeak_voice("ja")         # None: eSpeak reads kanji as "Chinese letter" and Chinese with tone numbers, so
                               # Chinese and Japanese words are timed by the recogniser, never by eSpeak

No imports beyond the standard library: the settings' validator checks a language against LANGUAGES.
"""
from __future__ import annotations

AUTO = "auto"
ENGLISH = "en"
# Whisper's languages (its code -> English name), as the multilingual recogniser (Whisper base) knows them.
LANGUAGES: dict[str, str] = {
    "en": "English", "zh": "Chinese", "de": "German", "es": "Spanish", "ru": "Russian", "ko": "Korean",
    "fr": "French", "ja": "Japanese", "pt": "Portuguese", "tr": "Turkish", "pl": "Polish", "ca": "Catalan",
    "nl": "Dutch", "ar": "Arabic", "sv": "Swedish", "it": "Italian", "id": "Indonesian", "hi": "Hindi",
    "fi": "Finnish", "vi": "Vietnamese", "he": "Hebrew", "uk": "Ukrainian", "el": "Greek", "ms": "Malay",
    "cs": "Czech", "ro": "Romanian", "da": "Danish", "hu": "Hungarian", "ta": "Tamil", "no": "Norwegian",
    "th": "Thai", "ur": "Urdu", "hr": "Croatian", "bg": "Bulgarian", "lt": "Lithuanian", "la": "Latin",
    "mi": "Maori", "ml": "Malayalam", "cy": "Welsh", "sk": "Slovak", "te": "Telugu", "fa": "Persian",
    "lv": "Latvian", "bn": "Bengali", "sr": "Serbian", "az": "Azerbaijani", "sl": "Slovenian", "kn": "Kannada",
    "et": "Estonian", "mk": "Macedonian", "br": "Breton", "eu": "Basque", "is": "Icelandic", "hy": "Armenian",
    "ne": "Nepali", "mn": "Mongolian", "bs": "Bosnian", "kk": "Kazakh", "sq": "Albanian", "sw": "Swahili",
    "gl": "Galician", "mr": "Marathi", "pa": "Punjabi", "si": "Sinhala", "km": "Khmer", "sn": "Shona",
    "yo": "Yoruba", "so": "Somali", "af": "Afrikaans", "oc": "Occitan", "ka": "Georgian", "be": "Belarusian",
    "tg": "Tajik", "sd": "Sindhi", "gu": "Gujarati", "am": "Amharic", "yi": "Yiddish", "lo": "Lao", "uz": "Uzbek",
    "fo": "Faroese", "ht": "Haitian Creole", "ps": "Pashto", "tk": "Turkmen", "nn": "Nynorsk", "mt": "Maltese",
    "sa": "Sanskrit", "lb": "Luxembourgish", "my": "Myanmar", "bo": "Tibetan", "tl": "Tagalog", "mg": "Malagasy",
    "as": "Assamese", "tt": "Tatar", "haw": "Hawaiian", "ln": "Lingala", "ha": "Hausa", "ba": "Bashkir",
    "jw": "Javanese", "su": "Sundanese",
}
CHOICES: tuple[str, ...] = (AUTO, *LANGUAGES)          # what --language and the page accept
# eSpeak NG's voice for a Whisper code where the names differ; codes missing here and from NO_ESPEAK use their own.
_ESPEAK = {"en": "en-us", "fr": "fr-fr", "no": "nb", "nn": "nb", "pt": "pt", "fa": "fa"}
# Scripts eSpeak does not read as the language: Chinese (tone numbers, no words) and Japanese (kanji read as
# "Chinese letter"); no voice in eSpeak NG 1.51/1.52: Tibetan, Breton, Faroese, Galician, Hausa, ... (checked against
# `espeak-ng --voices`).
NO_ESPEAK = frozenset({"zh", "ja", "yue", "bo", "br", "fo", "gl", "ha", "jw", "km", "ln", "lo", "mg", "mn", "oc", "ps",
                       "sa", "sn", "so", "su", "tg", "tl", "yi", "yo"})
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


def espeak_voice(code: str) -> str | None:
    """The eSpeak NG voice that reads transcripts of `code` (a Whisper code), or None where eSpeak cannot."""
    if code in NO_ESPEAK or code not in LANGUAGES:
        return None
    return _ESPEAK.get(code, code)


def has_cjk(text: str) -> bool:
    """Han or kana in `text`: a transcript eSpeak cannot read (Chinese, Japanese)."""
    return any("\u3040" <= c <= "\u30ff" or "\u3400" <= c <= "\u4dbf" or "\u4e00" <= c <= "\u9fff"
               or "\uf900" <= c <= "\ufaff" for c in text)


__all__ = ["AUTO", "CHOICES", "ENGLISH", "LANGUAGES", "NOT_FOR_GESTURES", "NO_ESPEAK", "NO_SPACES", "espeak_voice",
           "gesture_words", "has_cjk", "name"]
