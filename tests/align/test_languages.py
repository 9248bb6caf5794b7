"""Typed transcripts in other languages are aligned with their own eSpeak NG voice (the page's and the CLI's
--language): eSpeak Spanish and German speech with known word onsets, spoken by a voice variant the aligner does not
use, with pauses inserted; and Chinese / Japanese, which eSpeak does not read, are spread with a warning."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.align import AlignConfig, align_words
from gesturelsm.align.languages import typed_alignment

SPANISH = "ayer por la tarde fuimos al mercado con mi hermana y compramos pan fresco manzanas y una botella de leche"
GERMAN = ("gestern nachmittag sind wir mit dem fahrrad zum markt gefahren und haben frisches brot äpfel und eine "
          "flasche milch gekauft")


@pytest.mark.parametrize("language, text, voice", [("es", SPANISH, "es+m3"), ("de", GERMAN, "de+m3")])
def test_a_typed_transcript_is_aligned_with_its_own_voice(clip_maker, language, text, voice):
    clip = clip_maker(text.split(), voice=voice, pauses={6: 0.9, 12: 0.5})
    res = align_words(clip.audio, text, typed_alignment(language, text))
    assert res.method == "dtw" and [w.text for w in res.words] == text.split()
    assert res.details["voices"][0] == f"{language}+klatt"                      # its own language's voices
    err = np.abs([w.start - t for w, t in zip(res.words, clip.onsets)])
    assert np.mean(err) < 0.08 and np.mean(err < 0.1) >= 0.85
    assert all(b.start > a.start for a, b in zip(res.words, res.words[1:]))


def test_its_own_voice_beats_the_english_voice(clip_maker):
    clip = clip_maker(GERMAN.split(), voice="de+m3", pauses={6: 0.9})
    own = align_words(clip.audio, GERMAN, typed_alignment("de", GERMAN))
    english = align_words(clip.audio, GERMAN, AlignConfig())
    errors = [np.mean(np.abs([w.start - t for w, t in zip(r.words, clip.onsets)])) for r in (own, english)]
    assert errors[0] < errors[1]


@pytest.mark.parametrize("language, text", [("ja", "きのう ともだちと ひるごはんを たべました"),
                                            ("zh", "我们昨天在公园散步")])
def test_scripts_espeak_does_not_read_are_spread_with_a_warning(clip, language, text):
    res = align_words(clip.audio, text, typed_alignment(language, text))
    assert res.method == "even" and "does not read this language" in res.warning
    assert len(res.words) == len(text.replace(" ", ""))                         # one word per character
    assert all(b.start > a.start for a, b in zip(res.words, res.words[1:]))
