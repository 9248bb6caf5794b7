"""Praat TextGrid files: read any tier (long or short text format), write a words tier (long or short).

Writing uses praatio (maintained, exact Praat output). Reading uses the small tokenizer below instead of
praatio's reader, because praatio parses with whole-file regular expressions and cannot say where a broken
file breaks: here every error is a `TextGridError` naming the file and line. Both Praat text formats are the
same stream of values (numbers, "strings" with "" for a quote, <flags>); labels such as `xmin =` and
`intervals [3]:` and `!` comments are skipped. UTF-8, UTF-16 (with BOM) and Latin-1 files are accepted.

Times are seconds. Empty intervals are silence and are not returned as words.
"""
from __future__ import annotations

import bisect
import re
from dataclasses import dataclass
from pathlib import Path

from .words import AlignmentResult, Word
from ..errors import TextGridError

_TOKEN = re.compile(r'"(?:[^"]|"")*"?|![^\n]*|<[A-Za-z]+>|[^\s"]+')  # strings may span lines
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_LABEL = re.compile(r"^(?:[A-Za-z_][\w?]*(?:\[\d*\])?:?|=|\[\d*\]:?|:)$")  # skipped: keys, '=', '[3]:'
_EPS = 1e-6


@dataclass(frozen=True)
class Tier:
    name: str
    kind: str                                   # "IntervalTier" or "TextTier"
    xmin: float
    xmax: float
    items: list[tuple[float, float, str]]       # intervals (start, end, text); points as (t, t, mark)


@dataclass(frozen=True)
class TextGrid:
    xmin: float
    xmax: float
    tiers: list[Tier]

    def tier(self, name: str) -> Tier:
        for t in self.tiers:
            if t.name == name:
                return t
        raise KeyError(name)


class _Values:
    """The value stream of a Praat text file, with the line of each value for error messages."""

    def __init__(self, text: str, source: str):
        self.source = source
        newlines = [m.start() for m in re.finditer("\n", text)]
        self.items: list[tuple[str, int]] = []
        self.multiline: list[tuple[int, int]] = []  # (first, last) line of strings that span lines
        for m in _TOKEN.finditer(text):
            tok = m.group(0)
            if tok.startswith("!") or _LABEL.match(tok):
                continue
            line = bisect.bisect_right(newlines, m.start()) + 1
            if tok.startswith('"') and "\n" in tok:
                self.multiline.append((line, line + tok.count("\n")))
            self.items.append((tok, line))
        if self.items and self.items[-1][0].startswith('"') and not _closed(self.items[-1][0]):
            raise self.error(self.items[-1][1], 'a quoted text is never closed (missing ")')
        self.pos = 0
        self.last_line = len(newlines) + 1

    def _next(self, what: str) -> tuple[str, int]:
        if self.pos >= len(self.items):
            raise TextGridError(f"{self.source}, line {self.last_line}: file ends early; expected {what}")
        tok = self.items[self.pos]
        self.pos += 1
        return tok

    def error(self, line: int, msg: str) -> TextGridError:
        spans = [(a, b) for a, b in self.multiline if a <= line]
        if spans:  # an unbalanced quote earlier shifts everything after it
            msg += (f" (the text that starts on line {spans[0][0]} runs on to line {spans[0][1]}: "
                    "a missing or extra quote there?)")
        return TextGridError(f"{self.source}, line {line}: {msg}")

    def number(self, what: str) -> tuple[float, int]:
        tok, line = self._next(what)
        if not _NUMBER.fullmatch(tok):
            raise self.error(line, f"expected a number ({what}), found {tok[:40]!r}")
        return float(tok), line

    def count(self, what: str) -> tuple[int, int]:
        value, line = self.number(what)
        if value < 0 or value != int(value):
            raise self.error(line, f"expected a count ({what}), found {value:g}")
        return int(value), line

    def string(self, what: str) -> tuple[str, int]:
        tok, line = self._next(what)
        if not (len(tok) >= 2 and tok[0] == tok[-1] == '"'):
            raise self.error(line, f'expected a "quoted" string ({what}), found {tok[:40]!r}')
        return tok[1:-1].replace('""', '"'), line

    def flag(self) -> tuple[str | None, int]:
        """<exists> / <absent>, or None (and nothing consumed) when the next value is not a flag."""
        if self.pos < len(self.items) and self.items[self.pos][0].startswith("<"):
            tok, line = self._next("a flag")
            return tok, line
        return None, self.items[self.pos][1] if self.pos < len(self.items) else self.last_line


def _closed(tok: str) -> bool:
    """A string token is closed when, after its opening quote, it ends in an odd number of quotes."""
    rest = tok[1:]
    return (len(rest) - len(rest.rstrip('"'))) % 2 == 1


def _decode(data: bytes) -> str:
    if data[:2] in (b"\xff\xfe", b"\xfe\xff"):
        return data.decode("utf-16")
    if data[:3] == b"\xef\xbb\xbf":
        return data[3:].decode("utf-8")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def parse_textgrid(text: str, source: str = "TextGrid", max_intervals: int | None = None) -> TextGrid:
    """Parse the text of a TextGrid (long or short format); a tier declaring more than `max_intervals`
    intervals or points is refused before they are read."""
    if text.lstrip().startswith('File type = "ooBinaryFile"') or text.startswith("ooBinaryFile"):
        raise TextGridError(f"{source}: binary TextGrid; save it from Praat as a text file")
    if not text.strip():
        raise TextGridError(f"{source}: empty file, not a TextGrid")
    v = _Values(text, source)
    if not v.items:
        raise TextGridError(f'{source}, line 1: not a Praat TextGrid (no File type = "ooTextFile" header)')
    file_type, line = v.string("file type")
    if file_type != "ooTextFile":
        raise v.error(line, f'not a Praat text file (file type {file_type!r}, expected "ooTextFile")')
    cls, line = v.string("object class")
    if cls != "TextGrid":
        raise v.error(line, f'not a TextGrid (object class {cls!r})')
    xmin, _ = v.number("xmin")
    xmax, line = v.number("xmax")
    if xmax < xmin:
        raise v.error(line, f"xmax {xmax:g} is before xmin {xmin:g}")
    flag, line = v.flag()
    if flag == "<absent>":
        return TextGrid(xmin, xmax, [])
    if flag not in (None, "<exists>"):
        raise v.error(line, f"expected <exists> or <absent>, found {flag}")
    n_tiers, _ = v.count("number of tiers")
    return TextGrid(xmin, xmax, [_read_tier(v, max_intervals) for _ in range(n_tiers)])


def _read_tier(v: _Values, max_items: int | None = None) -> Tier:
    kind, line = v.string("tier class")
    if kind not in ("IntervalTier", "TextTier"):
        raise v.error(line, f'unknown tier class {kind!r} (expected "IntervalTier" or "TextTier")')
    name, _ = v.string("tier name")
    xmin, _ = v.number("tier xmin")
    xmax, _ = v.number("tier xmax")
    n, n_line = v.count("number of intervals" if kind == "IntervalTier" else "number of points")
    if max_items is not None and n > max_items:
        raise v.error(n_line, f"tier {name!r} has {n} intervals; at most {max_items} are accepted for this speech")
    items: list[tuple[float, float, str]] = []
    prev_end = -float("inf")
    for k in range(n):
        if kind == "IntervalTier":
            start, start_line = v.number(f"start of interval {k + 1} in tier {name!r}")
            end, line = v.number(f"end of interval {k + 1} in tier {name!r}")
            text, _ = v.string(f"text of interval {k + 1} in tier {name!r}")
            if end < start:
                raise v.error(line, f"interval {k + 1} of tier {name!r} ends ({end:g}) before it starts ({start:g})")
            if start < prev_end - _EPS:
                raise v.error(start_line, f"interval {k + 1} of tier {name!r} starts at {start:g}, before the "
                                          f"previous one ends ({prev_end:g})")
            prev_end = end
        else:
            start, line = v.number(f"time of point {k + 1} in tier {name!r}")
            text, _ = v.string(f"mark of point {k + 1} in tier {name!r}")
            end = start
        items.append((start, end, text))
    return Tier(name, kind, xmin, xmax, items)


def read_textgrid(path: str | Path, max_intervals: int | None = None) -> TextGrid:
    """Read a TextGrid file (Praat long or short text format); see parse_textgrid for max_intervals."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise TextGridError(f"TextGrid not found: {path}") from None
    except OSError as exc:
        raise TextGridError(f"cannot read {path}: {exc.strerror}") from None
    return parse_textgrid(_decode(data), path.name, max_intervals)


def words_from(tg: TextGrid, tier: str | None = None, source: str = "TextGrid") -> list[Word]:
    """Non-empty intervals of the words tier: `tier` if given, else the tier named "words" (any case),
    else the only interval tier."""
    intervals = [t for t in tg.tiers if t.kind == "IntervalTier"]
    if tier is not None:
        chosen = [t for t in intervals if t.name == tier]
    else:
        chosen = [t for t in intervals if t.name.lower() == "words"] or (intervals if len(intervals) == 1 else [])
    if not chosen:
        names = ", ".join(repr(t.name) for t in tg.tiers) or "none"
        want = f"an interval tier named {tier!r}" if tier else 'an interval tier named "words"'
        raise TextGridError(f"{source}: no words tier ({want}; tiers: {names})")
    return [Word(text.strip(), start, end) for start, end, text in chosen[0].items if text.strip()]


def read_words(path: str | Path, tier: str | None = None, max_intervals: int | None = None) -> list[Word]:
    """Words (non-empty intervals) of a TextGrid file's words tier, in time order."""
    return words_from(read_textgrid(path, max_intervals), tier, Path(path).name)


def read_result(path: str | Path, tier: str | None = None, max_intervals: int | None = None) -> AlignmentResult:
    """A TextGrid upload as an alignment: method "textgrid", confidence 1 (a warning when it has no words)."""
    words = read_words(path, tier, max_intervals)
    warning = None if words else f"{Path(path).name} has no words (only silence): using the audio only."
    return AlignmentResult(words, 1.0 if words else 0.0, "textgrid" if words else "audio-only", warning)


def write_textgrid(path: str | Path, words: list[Word], duration: float | None = None, fmt: str = "long",
                   tier: str = "words") -> None:
    """Write `words` as one interval tier (gaps become empty intervals), Praat "long" or "short" text.

    The grid spans [0, duration] (default: the last word's end). Overlapping words are cut at the next
    word's start; words must have positive length after that."""
    from praatio import textgrid as ptg

    if fmt not in ("long", "short"):
        raise TextGridError(f"TextGrid format must be 'long' or 'short', not {fmt!r}")
    entries = _clean_intervals(words)
    end = max([e for _, e, _ in entries] + [duration or 0.0])
    if end <= 0:
        raise TextGridError(f"{Path(path).name}: nothing to write (no words and no duration)")
    grid = ptg.Textgrid(0.0, end)
    grid.addTier(ptg.IntervalTier(tier, entries, 0.0, end))
    grid.save(str(path), format=f"{fmt}_textgrid", includeBlankSpaces=True, reportingMode="error")


def _clean_intervals(words: list[Word]) -> list[tuple[float, float, str]]:
    out: list[tuple[float, float, str]] = []
    ordered = sorted(words, key=lambda w: w.start)
    for k, w in enumerate(ordered):
        end = min(w.end, ordered[k + 1].start) if k + 1 < len(ordered) else w.end
        if w.start < 0 or end - w.start <= 0:
            raise TextGridError(f"word {k + 1} ({w.text!r}) has no duration ({w.start:.3f}-{w.end:.3f} s)")
        out.append((float(w.start), float(end), w.text.replace("\n", " ")))
    return out
