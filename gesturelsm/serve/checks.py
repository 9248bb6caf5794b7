"""The web request's checks that run before any work (the app service raises its error from the problems
these return; see `gesturelsm.serve.limits` for the rules and the numbers).

- `check_request`: every field of a `Request` as a browser or API client may send it -> a normalised
  request and the list of problems, one line each, all fields at once.
- `textgrid_words`: an uploaded TextGrid, refused by size before it is parsed and by interval count
  before a tier is read (both scale with the speech's length), then clipped to the audio: words after its
  end are dropped with a note, and a TextGrid with no word inside the audio is a problem (it would
  silently make the run audio-only while being labelled as using the transcript).
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

from ..align import TextGridError, read_result
from ..backends import MAX_CFG
from ..presentation import steps_setting_name
from . import limits
from .limits import SEED_MAX, method_list, one_of, real_number, switch, transcript_problems, whole_number


def method_steps(raw: Any, chosen: Sequence[str] | None, facts: Mapping[str, Any], p: list[str]) -> dict | None:
    """Steps per method from one value for every chosen method or a {method: value} mapping (the page sends its two
    sliders that way, `presentation.steps_from_flags`). Each value is checked against its method's registered bound and named
    after the setting that drives it ("Steps", "DDIM steps"); the same problem is said once."""
    items = dict(raw) if isinstance(raw, Mapping) else {m: raw for m in (chosen or []) if m in facts}
    steps, found = {}, []
    for m, value in items.items():
        if m not in facts:
            continue                                    # not a generator (ground truth) or not loaded: no steps
        steps[m] = whole_number(value, steps_setting_name(m), 1, facts[m].max_steps, found)
    p += list(dict.fromkeys(found))
    return None if found else steps


def check_request(req: Any, methods: list[str], settings: Any, smoothing_choices: Iterable[str],
                  sizes: Sequence[int], facts: Mapping[str, Any]) -> tuple[Any, list[str]]:
    """(request with normalised values, problems). `settings` gives max_seconds; `facts` the methods' registered
    facts (step bounds, which setting drives their steps)."""
    p: list[str] = []
    chosen = method_list(req.methods, methods, p)
    steps = method_steps(req.steps, chosen, facts, p)
    cfg = real_number(req.cfg, "CFG scale", 0.0, MAX_CFG, p)
    seed = whole_number(req.seed, "Seed", 0, SEED_MAX, p)
    smoothing = one_of(req.smoothing, "Smoothing", smoothing_choices, p)
    size = whole_number(req.size, "Video size", min(sizes), max(sizes), p)
    if size is not None:
        size = one_of(size, "Video size", sizes, p)
    in_place = switch(req.stand_in_place, "Stand in place", p)
    grounding = switch(req.grounding, "Feet on the ground", p)
    exports = switch(req.exports, "Exports", p)
    transcribe = switch(req.transcribe, "Automatic transcription", p)
    text = "" if req.text is None else req.text
    p += transcript_problems(text, settings.max_seconds, "of speech (the longest accepted)")
    if req.textgrid_path is not None and not isinstance(req.textgrid_path, (str, Path)):
        p.append(f"The TextGrid must be an uploaded file (got {type(req.textgrid_path).__name__}).")
    if p:
        return req, p
    return replace(req, methods=chosen, steps=steps, cfg=cfg, seed=seed, smoothing=smoothing, size=size,
                   stand_in_place=in_place, grounding=grounding, exports=exports, transcribe=transcribe, text=text), []


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
