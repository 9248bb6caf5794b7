"""Single values as an entry point received them, checked: each check returns the normalised value, or None after
adding one sentence to `problems` that names the field as the person sees it and says what is accepted. Nothing
raises, so every problem of a request is found at once.

Values arrive as whatever a browser, an API client or a command line sent (None, strings, floats such as 1.5,
1e30 or NaN, huge integers); nothing is converted before it is checked. The command line's text goes through
`from_text` first, so "8" is the number 8 and "inf" the float infinity (refused where a whole number is asked).
"""
from __future__ import annotations

import math
import numbers
from typing import Any, Callable, Iterable

from ..asr.languages import CHOICES

Check = Callable[[Any, str, list], Any]       # (value, field, problems) -> the normalised value, or None


def shown(value: Any) -> str:
    """`value` as a message quotes it, at most 40 characters."""
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def from_text(text: Any) -> Any:
    """Command-line text as the number it spells ("8" -> 8, "2.5" -> 2.5, "inf" -> inf); anything else unchanged,
    for the checks to refuse with their message."""
    if not isinstance(text, str):
        return text
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


def whole_number(value: Any, field: str, lo: int, hi: int, problems: list[str]) -> int | None:
    """`value` as an int in [lo, hi]; floats count only when whole (2.0 yes, 2.5 no); bools never."""
    if value is None or (isinstance(value, str) and not value.strip()):
        problems.append(f"{field} is empty: give a whole number from {lo} to {hi}.")
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        problems.append(f"{field} must be a whole number from {lo} to {hi} (got {shown(value)}).")
        return None
    if isinstance(value, numbers.Integral):
        number = int(value)
    elif math.isfinite(float(value)) and float(value).is_integer():
        number = int(float(value))
    else:
        problems.append(f"{field} must be a whole number from {lo} to {hi} (got {shown(value)}; "
                        "it is not rounded for you).")
        return None
    if not lo <= number <= hi:
        problems.append(f"{field} must be from {lo} to {hi} (got {shown(value)}).")
        return None
    return number


def real_number(value: Any, field: str, lo: float, hi: float, problems: list[str]) -> float | None:
    """`value` as a finite float in [lo, hi]."""
    if value is None or (isinstance(value, str) and not value.strip()):
        problems.append(f"{field} is empty: give a number from {lo:g} to {hi:g}.")
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(float(value)):
        problems.append(f"{field} must be a number from {lo:g} to {hi:g} (got {shown(value)}).")
        return None
    if not lo <= float(value) <= hi:
        problems.append(f"{field} must be between {lo:g} and {hi:g} (got {shown(value)}).")
        return None
    return float(value)


def number_list(value: Any, field: str, whole: bool, problems: list[str]) -> tuple | None:
    """A list of numbers ("1 2, 4", a list or one number) in order without repeats, each value's type checked
    (`whole`: whole numbers); the bounds are checked by the caller, per method."""
    parts = value.replace(",", " ").split() if isinstance(value, str) else \
        list(value) if isinstance(value, (list, tuple)) else [value]
    out, bad = [], []
    for part in map(from_text, parts):
        ok = not isinstance(part, bool) and isinstance(part, numbers.Real) and math.isfinite(float(part))
        if ok and whole and not float(part).is_integer():
            ok = False
        if not ok:
            bad.append(part)
        elif (int(part) if whole else float(part)) not in out:
            out.append(int(part) if whole else float(part))
    if bad:
        kind = "whole numbers" if whole else "numbers"
        problems.append(f"{field} must be {kind} (got {shown(bad[0])}).")
        return None
    if not out:
        problems.append(f"{field} is empty: give at least one.")
        return None
    return tuple(out)


def one_of(value: Any, field: str, choices: Iterable, problems: list[str]) -> Any:
    choices = list(choices)
    if isinstance(value, bool) or value not in choices:
        problems.append(f"{field} must be one of {', '.join(map(str, choices))} (got {shown(value)}).")
        return None
    return value


def switch(value: Any, field: str, problems: list[str]) -> bool | None:
    """A checkbox: True/False (None, 0 and 1 are read as such)."""
    if value is None or value in (0, 1):
        return bool(value)
    problems.append(f"{field} must be true or false (got {shown(value)}).")
    return None


def method_list(value: Any, available: list[str], problems: list[str], field: str = "Methods") -> list[str] | None:
    """Chosen methods in order, without repeats."""
    if value is None or (isinstance(value, (list, tuple)) and not value):
        problems.append("Choose at least one method to show.")
        return None
    if not isinstance(value, (list, tuple)) or not all(isinstance(m, str) for m in value):
        problems.append(f"{field} must be a list of names from {', '.join(available)} (got {shown(value)}).")
        return None
    unknown = [m for m in value if m not in available]
    if unknown:
        problems.append(f"Unknown method {shown(unknown[0])}; available: {', '.join(available)}.")
        return None
    return list(dict.fromkeys(value))


def whole_in(lo: int, hi: int) -> Check:
    """The check of a whole number from `lo` to `hi`."""
    return lambda value, field, problems: whole_number(value, field, lo, hi, problems)


def choice(choices: Iterable) -> Check:
    """The check of one of `choices`."""
    options = list(choices)
    return lambda value, field, problems: one_of(value, field, options, problems)


def check_language(value: Any, field: str, problems: list[str]) -> str | None:
    """"auto" or one of the recogniser's language codes (asr.languages.LANGUAGES), as sent (any case, spaces)."""
    code = value.strip().lower() if isinstance(value, str) else value
    if code not in CHOICES:
        problems.append(f"{field} must be auto or a language code such as en, ja, zh, es, de, fr "
                        f"(got {shown(value)}; the list: gesturelsm transcribe --help).")
        return None
    return code


__all__ = ["check_language", "choice", "from_text", "whole_in",
           "method_list", "number_list", "one_of", "real_number", "shown", "switch", "whole_number"]
