"""Transcript tokens: original spelling kept for display, spoken form normalised for the synthesiser."""
from __future__ import annotations

import pytest

from gesturelsm.align.normalize import number_words, ordinal_words, speak, tokenize, year_words


def test_punctuation_casing_and_unicode_are_normalised_but_the_original_is_kept():
    toks = tokenize("“Hello,” she said — I’m FINE!!  (really...)  Ｃａｆé")
    assert [t.text for t in toks] == ["Hello", "she", "said", "I'm", "FINE", "really", "Café"]
    assert [t.spoken for t in toks] == ["hello", "she", "said", "i'm", "fine", "really", "café"]


@pytest.mark.parametrize("token, spoken", [
    ("0", "zero"), ("7", "seven"), ("13", "thirteen"), ("40", "forty"), ("21", "twenty one"),
    ("105", "one hundred five"), ("1,000", "one thousand"), ("2,500,000", "two million five hundred thousand"),
    ("1990", "nineteen ninety"), ("2005", "two thousand five"), ("2024", "twenty twenty four"),
    ("1990s", "nineteen nineties"), ("3.5", "three point five"), ("50%", "fifty percent"),
    ("$20", "twenty dollars"), ("$5.50", "five dollars fifty"), ("1st", "first"), ("22nd", "twenty second"),
    ("3rd", "third"), ("12th", "twelfth"), ("40th", "fortieth"), ("mp3", "mp three"), ("&", "and"),
])
def test_numbers_and_symbols_are_spoken(token, spoken):
    assert speak(token) == spoken
    assert [t.spoken for t in tokenize(f"x {token} y")][1] == spoken


def test_number_helpers_cover_large_and_edge_values():
    assert number_words(999_999) == "nine hundred ninety nine thousand nine hundred ninety nine"
    assert number_words(10**12) == "one trillion"
    assert year_words(1900) == "nineteen hundred" and year_words(1905) == "nineteen oh five"
    assert year_words(2000) == "two thousand"
    assert ordinal_words(101) == "one hundred first"


def test_tokens_without_sound_are_dropped_and_cjk_is_split_per_character():
    assert tokenize("... -- !!! ' ") == []
    assert [t.text for t in tokenize("我喜欢 music")] == ["我", "喜", "欢", "music"]


def test_other_languages_leave_numbers_to_the_synthesiser():
    assert [t.spoken for t in tokenize("Ich habe 21 Äpfel", language="de")] == ["ich", "habe", "21", "äpfel"]
