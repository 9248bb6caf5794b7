"""The page's motion statistics: one row per shown motion and the shipped speaker's reference row, under the timing
table (element id `motion-stats`), each column's heading carrying a tooltip (what it measures, which way is better).

Computed in an event of its own each time the motions handed to the player grow (`attach`), so the player never
waits for them;
the numbers are `gesturelsm.evaluation.motion_stats`' (the definitions `gesturelsm eval` uses). Each cell carries its
unrounded value in `data-value` for tools and tests.
"""
from __future__ import annotations

import html
import logging
import time
from collections import OrderedDict
from dataclasses import dataclass

import gradio as gr

from gesturelsm.evaluation.motion_stats import (STATISTICS, SpeakerReference, SpeechContext, format_value,
                                                motion_statistics, speaker_reference)

from .aside import aside
from .layout import SCROLL

log = logging.getLogger("gesturelsm.app")
ELEMENT_ID = "motion-stats"
EMPTY = f'<div id="{ELEMENT_ID}" data-state="empty"></div>'


@dataclass
class StatsTable:
    rows: list[tuple[str, str, dict[str, float]]]     # (label, method, statistics) per shown motion
    reference: SpeakerReference | None
    seconds: float                                    # time to compute all rows


_DONE: OrderedDict[tuple[str, str], dict[str, float]] = OrderedDict()     # (request folder, method) -> statistics
_KEEP = 256


def compute(out) -> StatsTable | None:
    """Statistics of every motion of a generated request (`serve.request.Result`: its motions by method, and its render
    job's labels and speech). A request whose methods arrive one by one is computed again as each arrives: the rows
    computed before are reused (by request folder and method), so `seconds` is the time of the new rows."""
    if out is None or not out.motions or out.job.audio is None:
        return None
    t0 = time.perf_counter()
    ref = speaker_reference()
    speech = None
    labels = list(out.job.labels) + list(out.motions)[len(out.job.labels):]
    rows = []
    for label, (method, m) in zip(labels, out.motions.items()):
        key = (str(out.job.folder), method)
        if key not in _DONE:
            speech = speech or SpeechContext.of(out.job.audio, None if ref is None else ref.mean_speed)
            _DONE[key] = motion_statistics(m, None, speech)
            while len(_DONE) > _KEEP:
                _DONE.popitem(last=False)
        rows.append((label, method, _DONE[key]))
    return StatsTable(rows, ref, time.perf_counter() - t0)


def _head() -> str:
    cells = "".join(f'<th title="{html.escape(s.tooltip)}" data-key="{s.key}">{html.escape(s.label)}'
                    f'<br><small>{html.escape(s.unit)}</small></th>' for s in STATISTICS)
    return f"<tr><th>motion</th>{cells}</tr>"


def _row(label: str, method: str, stats: dict[str, float], title: str = "") -> str:
    cells = "".join(f'<td data-key="{s.key}" data-value="{stats[s.key]!r}">{format_value(s.key, stats[s.key])}</td>'
                    for s in STATISTICS)
    t = f' title="{html.escape(title)}"' if title else ""
    return f'<tr data-method="{html.escape(method)}"{t}><td>{html.escape(label)}</td>{cells}</tr>'


def to_html(table: StatsTable | None) -> str:
    if table is None:
        return EMPTY
    body = [_row(label, method, st) for label, method, st in table.rows]
    if table.reference is not None:
        body.append(_row("speaker (reference)", "speaker", table.reference.statistics, table.reference.source))
    note = (f"Motion statistics on the mannequin, computed in {table.seconds:.2f} s after the motion was shown; "
            "hover a "
            "heading for what it measures and which way is better. " +
            (f"Speaker row: {html.escape(table.reference.source)}." if table.reference else
             "No speaker row: assets/speaker_stats.json is missing (scripts/speaker_stats.py writes it)."))
    return (f'<div id="{ELEMENT_ID}" data-state="ready" data-seconds="{table.seconds:.4f}">'
            f'<div {SCROLL}><table class="motion-stats"><thead>{_head()}</thead><tbody>{"".join(body)}</tbody>'
            '</table></div>'
            f'<p><small>{note}</small></p></div>')


def show(out) -> str:
    """The follow-up event's handler: never fails the page (the motion is already playing)."""
    try:
        return to_html(aside(compute, out))                   # beside generating the next method, niced
    except Exception:                                         # a bug: log it, keep the page working
        log.exception("motion statistics failed")
        return EMPTY


def component() -> gr.HTML:
    return gr.HTML(EMPTY, elem_id=f"{ELEMENT_ID}-box", label="Motion statistics")


def attach(event, state, target: gr.HTML) -> None:
    """Compute the statistics whenever `event` fires (each time the motions handed to the player change: as they
    grow, after an edit, after an undo), in a pool of their own; a burst of such events computes once, for the
    newest."""
    event(show, state, target, api_name="motion_stats", api_visibility="private", show_progress="hidden",
          concurrency_limit=1, concurrency_id="stats", trigger_mode="always_last")


def values(html_text: str) -> dict[str, dict[str, float]]:
    """method -> {statistic: value} read back from the table's `data-value` attributes (tests and tools)."""
    import re

    out: dict[str, dict[str, float]] = {}
    for method, row in re.findall(r'<tr data-method="([^"]+)"[^>]*>(.*?)</tr>', html_text):
        out[method] = {k: float(v) for k, v in re.findall(r'data-key="(\w+)" data-value="([^"]+)"', row)}
    return out


__all__ = ["StatsTable", "attach", "component", "compute", "show", "to_html", "values"]
