"""Transcript text -> tokens: what to show (the original spelling) and what to say (for the synthesiser).

Rules: Unicode NFKC; tokens are runs of letters/digits with inner apostrophes, dots or commas in numbers
(`don't`, `3.5`, `1,000`, `$20`, `50%`, `21st`, `1990s`, `mp3`); every other character separates tokens
and is dropped (punctuation, dashes, slashes, emoji). Han/kana characters are one token each (those scripts
do not put spaces between words). The spoken form is case-folded, curly apostrophes become ', numbers are
written out in English words (`num2words`-style, no dependency) and `&`, `%`, `$`, `€`, `£`, `@`, `+` are said
(English only: for other languages the casefolded token is passed on, eSpeak reads numbers itself).
"""
from __future__ import annotations

import re
import unicodedata
from dataclasses import dataclass

_ONES = ("zero one two three four five six seven eight nine ten eleven twelve thirteen fourteen fifteen "
         "sixteen seventeen eighteen nineteen").split()
_TENS = "_ _ twenty thirty forty fifty sixty seventy eighty ninety".split()
_SCALES = ((10**12, "trillion"), (10**9, "billion"), (10**6, "million"), (1000, "thousand"))
_ORDINAL = {"one": "first", "two": "second", "three": "third", "five": "fifth", "eight": "eighth",
            "nine": "ninth", "twelve": "twelfth"}
_CURRENCY = {"$": "dollars", "€": "euros", "£": "pounds"}
_SYMBOLS = {"&": "and", "@": "at", "+": "plus", "%": "percent"}
_CJK = r"\u3040-\u30ff\u3400-\u4dbf\u4e00-\u9fff\uf900-\ufaff"

_TOKEN = re.compile(
    rf"[{_CJK}]"                                                  # one Han / kana character
    r"|[$€£]?\d[\d,]*(?:\.\d+)?(?:%|st|nd|rd|th|s|'s)?(?![^\W\d_])"  # number, money, percent, ordinal
    rf"|(?:[^\W_{_CJK}]|')+(?:['’.][^\W_{_CJK}]+)*"                  # word with inner apostrophes / dots
    r"|[&@+%]"
)


@dataclass(frozen=True)
class Token:
    """One transcript token: `text` as the user wrote it, `spoken` in lowercase words for the synthesiser."""

    text: str
    spoken: str


def tokenize(text: str, language: str = "en") -> list[Token]:
    """Tokens of a transcript, in order; tokens with nothing to say (a lone apostrophe) are dropped.
    For languages other than English ("en") numbers and symbols are left for the synthesiser to read."""
    text = unicodedata.normalize("NFKC", text).replace("’", "'").replace("‘", "'")
    out = []
    for m in _TOKEN.finditer(text):
        raw = m.group(0).strip("'")
        spoken = speak(raw) if language == "en" else raw.casefold()
        if spoken:
            out.append(Token(raw, spoken))
    return out


def speak(token: str) -> str:
    """Spoken form of one token: lowercase words separated by single spaces ('' if nothing to say)."""
    t = token.casefold().strip("'")
    if t in _SYMBOLS:
        return _SYMBOLS[t]
    m = re.fullmatch(r"([$€£]?)(\d[\d,]*)(?:\.(\d+))?(%|st|nd|rd|th|s|'s)?", t)
    if m:
        return _speak_number(*m.groups())
    parts = re.findall(r"\d+|[^\W\d_]+(?:'[^\W\d_]+)*", t.replace(".", " "))
    return " ".join(number_words(int(p)) if p.isdigit() else p for p in parts)


def _speak_number(cur: str, digits: str, frac: str | None, suffix: str | None) -> str:
    n = int(digits.replace(",", "")) if digits.replace(",", "") else 0
    plain = "," not in digits and frac is None and not cur
    if suffix in ("st", "nd", "rd", "th"):
        return ordinal_words(n)
    words = year_words(n) if plain and len(digits) == 4 and suffix in (None, "s", "'s") else number_words(n)
    if cur and frac and len(frac) == 2:  # $5.50 -> five dollars fifty
        return f"{words} {_CURRENCY[cur]}" + ("" if frac == "00" else " " + number_words(int(frac)))
    if frac:
        words += " point " + " ".join(_ONES[int(d)] for d in frac)
    if suffix in ("s", "'s"):
        words = _plural(words)
    if suffix == "%":
        words += " percent"
    if cur:
        words += " " + _CURRENCY[cur]
    return words


def number_words(n: int) -> str:
    """Cardinal in English words: 0 -> 'zero', 1234 -> 'one thousand two hundred thirty four'."""
    if n < 20:
        return _ONES[n]
    if n < 100:
        return _TENS[n // 10] + ("" if n % 10 == 0 else " " + _ONES[n % 10])
    if n < 1000:
        rest = n % 100
        return _ONES[n // 100] + " hundred" + ("" if rest == 0 else " " + number_words(rest))
    for value, name in _SCALES:
        if n >= value:
            if n // value >= 1000 and value == _SCALES[0][0]:  # beyond trillions: read the digits
                return " ".join(_ONES[int(d)] for d in str(n))
            rest = n % value
            return number_words(n // value) + " " + name + ("" if rest == 0 else " " + number_words(rest))
    raise AssertionError(n)


def year_words(n: int) -> str:
    """Four-digit numbers read as years where people do: 1990 -> 'nineteen ninety', 2005 -> 'two thousand
    five', 1900 -> 'nineteen hundred', 2024 -> 'twenty twenty four'."""
    hi, lo = divmod(n, 100)
    if n % 1000 < 10 and n % 1000 != 0 or n % 1000 == 0 or hi < 11:
        return number_words(n)
    if lo == 0:
        return number_words(hi) + " hundred"
    return number_words(hi) + (" oh " + _ONES[lo] if lo < 10 else " " + number_words(lo))


def ordinal_words(n: int) -> str:
    words = number_words(n).split()
    last = words[-1]
    if last in _ORDINAL:
        words[-1] = _ORDINAL[last]
    elif last.endswith("y"):
        words[-1] = last[:-1] + "ieth"
    else:
        words[-1] = last + "th"
    return " ".join(words)


def _plural(words: str) -> str:
    head, _, last = words.rpartition(" ")
    last = last[:-1] + "ies" if last.endswith("y") else last + ("es" if last.endswith("x") else "s")
    return (head + " " + last).strip()
