"""The web request's checks that run before any work (the app service raises its error from the problems
these return; `gesturelsm.settings` checks the generation settings, `gesturelsm.serve.limits` holds the text bounds).

- `check_request`: every field of a `Request` as a browser or API client may send it -> the request with
  normalised values, its settings and the list of problems, one line each, all fields at once.
- `textgrid_words`: an uploaded TextGrid, refused by size before it is parsed and by interval count
  before a tier is read (both scale with the speech's length), then clipped to the audio: words after its
  end are dropped with a note, and a TextGrid with no word inside the audio is a problem (it would
  silently make the run audio-only while being labelled as using the transcript).
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any, Sequence

from ..align import TextGridError, read_result
from ..settings import MISSING, PAGE, Asked, Limits, Settings, settings_of, settings_problems
from ..settings.values import one_of, switch, whole_number
from . import limits
from .limits import transcript_problems


def check_request(req: Any, available: Sequence[str], limits_: Limits, sizes: Sequence[int]
                  ) -> tuple[Any, Settings | None, list[str]]:
    """(request with normalised values, its settings, problems). `available`: the methods a visitor may choose;
    `limits_`: the server's (speech length, step caps)."""
    asked = Asked(**{s.name: getattr(req, s.name, MISSING) for s in settings_of()})     # each setting by its name
    settings, p = settings_problems(asked, available, limits_, PAGE)
    size = whole_number(req.size, "Video size", min(sizes), max(sizes), p)
    if size is not None:
        size = one_of(size, "Video size", sizes, p)
    exports = switch(req.exports, "Exports", p)
    text = "" if req.text is None else req.text
    p += transcript_problems(text, limits_.max_seconds, "of speech (the longest accepted)")
    if req.textgrid_path is not None and not isinstance(req.textgrid_path, (str, Path)):
        p.append(f"The TextGrid must be an uploaded file (got {type(req.textgrid_path).__name__}).")
    if p:
        return req, None, p
    return replace(req, methods=settings.methods, size=size, exports=exports, text=text), settings, []


def textgrid_words(path: str | Path, seconds: float) -> tuple[list | None, list[str], list[str]]:
    """(words inside the audio, problems, notes) for an uploaded TextGrid and `seconds` of speech."""
    path = Path(path)
    try:
        size = path.stat().st_size
    except OSError:
        return None, ["The TextGrid file is missing on the server; please upload it again."], []
    if size > limits.max_textgrid_bytes(seconds):
        return None, [f"The TextGrid is {size / 1024:.0f} KB; for {seconds:.1f} s of speech at most "
                      f"{limits.max_textgrid_bytes(seconds) / 1024:.0f} KB are accepted (about "
                      f"{limits.INTERVALS_PER_SECOND:g} intervals per second per tier)."], []
    try:
        words = read_result(path, max_intervals=limits.max_intervals(seconds)).words
    except TextGridError as exc:
        return None, [f"The TextGrid could not be read: {exc}"], []
    if not words:
        return None, [], [f"{path.name} has no words (only silence): the speech is used without a transcript."]
    inside = [w for w in words if w.start < seconds]
    if not inside:
        return None, [f"All {len(words)} words of the TextGrid lie after the end of the speech (the first starts "
                      f"at {words[0].start:.1f} s; the audio is {seconds:.1f} s long): is it the TextGrid of this "
                      "recording? Remove it to run audio-only."], []
    notes = []
    if len(inside) < len(words):
        notes.append(f"{len(words) - len(inside)} of the TextGrid's {len(words)} words start after the end of the "
                     f"speech ({seconds:.1f} s) and were ignored.")
    return inside, [], notes
