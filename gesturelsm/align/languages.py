"""The languages a request may name and which eSpeak NG voice reads a transcript typed in each (the aligner's side
of the language setting; gesturelsm.asr.languages adds which recogniser hears it and whether its words drive the
gestures).

    LANGUAGES["ja"]                  # "Japanese": Whisper's codes, the ones every --language and the page take
    espeak_voice("es")               # "es": a typed Spanish transcript is aligned with eSpeak's Spanish voice
    espeak_voice("ja")               # None: eSpeak reads kanji as "Chinese letter" and Chinese with tone numbers
    typed_alignment("de", text)      # the AlignConfig a typed German transcript is aligned with
"""
from __future__ import annotations

from .aligner import AlignConfig

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


def espeak_voice(code: str) -> str | None:
    """The eSpeak NG voice that reads transcripts of `code` (a Whisper code), or None where eSpeak cannot."""
    if code in NO_ESPEAK or code not in LANGUAGES:
        return None
    return _ESPEAK.get(code, code)


def has_cjk(text: str) -> bool:
    """Han or kana in `text`: a transcript eSpeak cannot read (Chinese, Japanese)."""
    return any("\u3040" <= c <= "\u30ff" or "\u3400" <= c <= "\u4dbf" or "\u4e00" <= c <= "\u9fff"
               or "\uf900" <= c <= "\ufaff" for c in text)


def typed_alignment(language: str, text: str) -> AlignConfig:
    """How a typed transcript in `language` (a code of CHOICES) is aligned: English voices for auto/en,
    the language's eSpeak NG voices where eSpeak reads it (Spanish "es", German "de", Russian "ru", ...), none for
    Chinese and Japanese (also a Han/kana transcript under auto): its characters are spread over the speech by length
    (the aligner says so; leaving the box empty has them recognised and timed by the recogniser)."""
    if language in (AUTO, ENGLISH):
        return AlignConfig.for_language(None) if has_cjk(text) else AlignConfig()
    return AlignConfig.for_language(espeak_voice(language))


__all__ = ["AUTO", "CHOICES", "ENGLISH", "LANGUAGES", "NO_ESPEAK", "espeak_voice", "has_cjk", "typed_alignment"]
