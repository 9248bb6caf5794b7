"""What one web request may ask for, checked before any work starts (the app service calls these).

Every check returns problems as sentences meant for the page (one line each, naming the field as the page
labels it and saying what is accepted), never raises: the caller decides the error type. Values arrive as
whatever a browser or an API client sent (None, strings, floats such as 1.5, 1e30 or NaN, huge integers),
so nothing is converted before it is checked; accepted values come back normalised (ints, floats, bools).

Work is bounded by the length of the speech: a transcript may have at most WORDS_PER_SECOND words (and
CHARS_PER_SECOND characters) per second of audio, a TextGrid at most INTERVALS_PER_SECOND intervals per tier
and TEXTGRID_BYTES_PER_SECOND bytes per second, each plus a small allowance for very short clips. Fast
speech is about 4-5 words and 12-15 phones per second, so real transcripts and MFA TextGrids (words and
phones tiers) stay well inside.
"""
from __future__ import annotations

import math
import numbers
from typing import Any, Iterable

SEED_MAX = 2 ** 32 - 1
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


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def whole_number(value: Any, field: str, lo: int, hi: int, problems: list[str]) -> int | None:
    """`value` as an int in [lo, hi]; floats count only when whole (2.0 yes, 2.5 no); bools never."""
    if value is None or (isinstance(value, str) and not value.strip()):
        problems.append(f"{field} is empty: give a whole number from {lo} to {hi}.")
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        problems.append(f"{field} must be a whole number from {lo} to {hi} (got {_shown(value)}).")
        return None
    if isinstance(value, numbers.Integral):
        number = int(value)
    elif math.isfinite(float(value)) and float(value).is_integer():
        number = int(float(value))
    else:
        problems.append(f"{field} must be a whole number from {lo} to {hi} (got {_shown(value)}; "
                        "it is not rounded for you).")
        return None
    if not lo <= number <= hi:
        problems.append(f"{field} must be from {lo} to {hi} (got {_shown(value)}).")
        return None
    return number


def real_number(value: Any, field: str, lo: float, hi: float, problems: list[str]) -> float | None:
    """`value` as a finite float in [lo, hi]."""
    if value is None or (isinstance(value, str) and not value.strip()):
        problems.append(f"{field} is empty: give a number from {lo:g} to {hi:g}.")
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(float(value)):
        problems.append(f"{field} must be a number from {lo:g} to {hi:g} (got {_shown(value)}).")
        return None
    if not lo <= float(value) <= hi:
        problems.append(f"{field} must be between {lo:g} and {hi:g} (got {_shown(value)}).")
        return None
    return float(value)


def one_of(value: Any, field: str, choices: Iterable, problems: list[str]) -> Any:
    choices = list(choices)
    if isinstance(value, bool) or value not in choices:
        problems.append(f"{field} must be one of {', '.join(map(str, choices))} (got {_shown(value)}).")
        return None
    return value


def switch(value: Any, field: str, problems: list[str]) -> bool | None:
    """A checkbox: True/False (None, 0 and 1 are read as such)."""
    if value is None or value in (0, 1):
        return bool(value)
    problems.append(f"{field} must be true or false (got {_shown(value)}).")
    return None


def method_list(value: Any, available: list[str], problems: list[str]) -> list[str] | None:
    """Chosen methods in order, without repeats."""
    if value is None or (isinstance(value, (list, tuple)) and not value):
        problems.append("Choose at least one method to show.")
        return None
    if not isinstance(value, (list, tuple)) or not all(isinstance(m, str) for m in value):
        problems.append(f"Methods must be a list of names from {', '.join(available)} (got {_shown(value)}).")
        return None
    unknown = [m for m in value if m not in available]
    if unknown:
        problems.append(f"Unknown method {_shown(unknown[0])}; available: {', '.join(available)}.")
        return None
    return list(dict.fromkeys(value))


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


__all__ = ["SEED_MAX", "max_chars", "max_intervals", "max_textgrid_bytes", "max_words", "method_list", "one_of",
           "real_number", "switch", "transcript_problems", "whole_number"]
