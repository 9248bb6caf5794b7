"""How much text one web request may send for its speech, checked before any work starts (the app service calls
these; the settings of a request are checked by `gesturelsm.settings`).

Work is bounded by the length of the speech: a transcript may have at most WORDS_PER_SECOND words (and
CHARS_PER_SECOND characters) per second of audio, a TextGrid at most INTERVALS_PER_SECOND intervals per tier
and TEXTGRID_BYTES_PER_SECOND bytes per second, each plus a small allowance for very short clips. Fast
speech is about 4-5 words and 12-15 phones per second, so real transcripts and MFA TextGrids (words and
phones tiers) stay well inside.
"""
from __future__ import annotations

from typing import Any

WORDS_PER_SECOND, WORDS_ALLOWANCE = 8.0, 20
CHARS_PER_SECOND, CHARS_ALLOWANCE = 60.0, 200
INTERVALS_PER_SECOND, INTERVALS_ALLOWANCE = 40.0, 100
TEXTGRID_BYTES_PER_SECOND, TEXTGRID_BYTES_ALLOWANCE = 40_000.0, 16_384     # UTF-16 long format, 3 tiers


def max_words(seconds: float) -> int:
    return int(WORDS_ALLOWANCE + WORDS_PER_SECOND * max(seconds, 0.0))


def max_chars(seconds: float) -> int:
    return int(CHARS_ALLOWANCE + CHARS_PER_SECOND * max(seconds, 0.0))


def max_intervals(seconds: float) -> int:
    """Intervals (or points) per TextGrid tier, empty ones included."""
    return int(INTERVALS_ALLOWANCE + INTERVALS_PER_SECOND * max(seconds, 0.0))


def max_textgrid_bytes(seconds: float) -> int:
    return int(TEXTGRID_BYTES_ALLOWANCE + TEXTGRID_BYTES_PER_SECOND * max(seconds, 0.0))


def transcript_problems(text: Any, seconds: float, what: str = "of speech") -> list[str]:
    """A transcript must be text with at most max_words/max_chars for `seconds` of audio."""
    if text is None or text == "":
        return []
    if not isinstance(text, str):
        return [f"The transcript must be text (got {type(text).__name__})."]
    words, chars = len(text.split()), len(text)
    if words > max_words(seconds) or chars > max_chars(seconds):
        return [f"The transcript has {words} words ({chars} characters); for {seconds:.1f} s {what} at most "
                f"{max_words(seconds)} words and {max_chars(seconds)} characters are accepted (about "
                f"{WORDS_PER_SECOND:g} words per second). Give the words that are actually spoken."]
    return []


__all__ = ["max_chars", "max_intervals", "max_textgrid_bytes", "max_words", "transcript_problems"]
