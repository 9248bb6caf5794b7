"""TextGrid reading and writing: round trips, both Praat formats, and errors that name the line."""
from __future__ import annotations

import pytest

from gesturelsm.align import TextGridError, Word, read_result, read_textgrid, read_words, write_textgrid
from gesturelsm.align.textgrid import parse_textgrid

WORDS = [Word("Hello", 0.5, 0.9), Word('say "hi"', 0.9, 1.25), Word("café", 1.6, 2.0), Word("5", 2.0, 2.3)]

LONG = '''File type = "ooTextFile"
Object class = "TextGrid"

xmin = 0
xmax = 3
tiers? <exists>
size = 2
item []:
    item [1]:
        class = "IntervalTier"
        name = "words"
        xmin = 0
        xmax = 3
        intervals: size = 3
        intervals [1]:
            xmin = 0
            xmax = 1.5
            text = ""
        intervals [2]:
            xmin = 1.5
            xmax = 2.25
            text = "good ""morning"""
        intervals [3]:
            xmin = 2.25
            xmax = 3
            text = "all"
    item [2]:
        class = "TextTier"
        name = "events"
        xmin = 0
        xmax = 3
        points: size = 1
        points [1]:
            number = 1.7
            mark = "clap"
'''

SHORT = '''File type = "ooTextFile"
Object class = "TextGrid"

0
3
<exists>
2
"IntervalTier"
"words"
0
3
3
0
1.5
""
1.5
2.25
"good ""morning"""
2.25
3
"all"
"TextTier"
"events"
0
3
1
1.7
"clap"
'''


@pytest.mark.parametrize("fmt", ["long", "short"])
def test_write_then_read_gives_the_same_words(tmp_path, fmt):
    path = tmp_path / f"w_{fmt}.TextGrid"
    write_textgrid(path, WORDS, duration=3.0, fmt=fmt)
    assert read_words(path) == WORDS
    grid = read_textgrid(path)
    assert (grid.xmin, grid.xmax) == (0.0, 3.0)
    texts = [t for _, _, t in grid.tier("words").items]
    assert texts == ["", "Hello", 'say "hi"', "", "café", "5", ""]  # the gaps are written as silence


def test_praatio_reads_what_we_write_and_we_read_what_it_writes(tmp_path):
    from praatio import textgrid as ptg

    write_textgrid(tmp_path / "ours.TextGrid", WORDS, 3.0, "short")
    entries = ptg.openTextgrid(str(tmp_path / "ours.TextGrid"), includeEmptyIntervals=False).getTier("words").entries
    assert [(e.start, e.end, e.label) for e in entries] == [(w.start, w.end, w.text) for w in WORDS]
    grid = ptg.Textgrid(0, 3)
    grid.addTier(ptg.IntervalTier("Words", [(0.2, 1.0, "one"), (1.3, 2.0, "two")], 0, 3))
    grid.save(str(tmp_path / "theirs.TextGrid"), format="long_textgrid", includeBlankSpaces=True)
    assert read_words(tmp_path / "theirs.TextGrid") == [Word("one", 0.2, 1.0), Word("two", 1.3, 2.0)]


def test_long_and_short_formats_parse_to_the_same_grid():
    long, short = parse_textgrid(LONG), parse_textgrid(SHORT)
    assert long == short
    assert long.tier("words").items[1] == (1.5, 2.25, 'good "morning"')
    assert long.tier("events").items == [(1.7, 1.7, "clap")]


def test_utf16_files_with_a_bom_are_read(tmp_path):
    path = tmp_path / "praat_utf16.TextGrid"
    path.write_bytes(LONG.replace('"all"', '"naïve"').encode("utf-16"))
    assert [w.text for w in read_words(path)] == ['good "morning"', "naïve"]


def test_the_words_tier_is_found_by_name_or_as_the_only_interval_tier(tmp_path):
    grid = parse_textgrid(SHORT.replace('"words"', '"Transcript"'))
    from gesturelsm.align.textgrid import words_from

    assert [w.text for w in words_from(grid)] == ['good "morning"', "all"]  # the only interval tier
    with pytest.raises(TextGridError, match="no words tier .*'Transcript'.*'events'"):
        words_from(grid, tier="words")


@pytest.mark.parametrize("broken, line, message", [
    (LONG.replace("xmax = 1.5\n            text = \"\"", "xmax = 1,5\n            text = \"\""), 17,
     "expected a number"),
    (LONG.replace("xmin = 2.25\n            xmax = 3", "xmin = 2.25\n            xmax = 2"), 25, "ends .* before"),
    (LONG.replace("xmin = 1.5\n            xmax = 2.25", "xmin = 1.2\n            xmax = 2.25"), 20,
     "before the previous one ends"),
    (LONG.replace('class = "IntervalTier"', 'class = "PointTier"'), 10, "unknown tier class"),
    (LONG[: LONG.index("intervals [3]")], 23, "file ends early"),
    (LONG.replace('text = "all"', 'text = "all'), 35, "starts on line 26 .*missing or extra quote"),
    (LONG.replace('Object class = "TextGrid"', 'Object class = "Sound"'), 2, "not a TextGrid"),
    ("hello world\n", 1, "not a Praat TextGrid"),
])
def test_malformed_files_are_rejected_with_the_line(tmp_path, broken, line, message):
    path = tmp_path / "broken.TextGrid"
    path.write_text(broken, encoding="utf-8")
    with pytest.raises(TextGridError, match=rf"broken.TextGrid, line {line}: .*{message}"):
        read_words(path)


def test_missing_empty_and_binary_files_give_clear_errors(tmp_path):
    with pytest.raises(TextGridError, match="not found"):
        read_words(tmp_path / "nope.TextGrid")
    (tmp_path / "empty.TextGrid").write_text("")
    with pytest.raises(TextGridError, match="empty.TextGrid: empty file"):
        read_words(tmp_path / "empty.TextGrid")
    (tmp_path / "bin.TextGrid").write_bytes(b'File type = "ooBinaryFile"\nTextGrid\x00\x01')
    with pytest.raises(TextGridError, match="binary"):
        read_words(tmp_path / "bin.TextGrid")


def test_an_upload_becomes_a_textgrid_result_and_an_empty_one_audio_only(tmp_path):
    write_textgrid(tmp_path / "w.TextGrid", WORDS, 3.0)
    result = read_result(tmp_path / "w.TextGrid")
    assert (result.method, result.confidence, result.warning, result.words) == ("textgrid", 1.0, None, WORDS)
    (tmp_path / "silent.TextGrid").write_text(LONG.replace('"good ""morning"""', '""').replace('"all"', '""'))
    empty = read_result(tmp_path / "silent.TextGrid")
    assert empty.method == "audio-only" and empty.words == [] and "no words" in empty.warning


def test_writing_words_without_duration_is_refused(tmp_path):
    with pytest.raises(TextGridError, match="no duration"):
        write_textgrid(tmp_path / "x.TextGrid", [Word("a", 1.0, 1.0)])


def test_real_mfa_textgrid_reads_all_words(beat2):
    words = read_words(beat2 / "textgrid" / "2_scott_0_1_1.TextGrid")
    assert len(words) == 199 and words[0] == Word("the", 1.42, 1.52)
    assert all(a.end <= b.start + 1e-9 for a, b in zip(words, words[1:]))
    assert len(read_textgrid(beat2 / "textgrid" / "2_scott_0_1_1.TextGrid").tier("phones").items) > 600
