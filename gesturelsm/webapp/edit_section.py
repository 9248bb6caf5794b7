"""The page's Edit section (shown after Generate): regenerate body regions of one shown motion over a time range,
keep the rest, compare, chain and undo (`GestureService.edit`, gesturelsm/serve/editing.py).

Element ids (contracts): `edit-start`, `edit-end` (the range in seconds; drawn on the player's timeline, and set to
the player's time by `edit-start-here` / `edit-end-here`), `edit-regions` (upper / hands / lower / face), `edit-seed`,
`edit-method` (which motion), `edit-run`, `edit-undo`; the player's A/B button is `edit-ab` (player.js). An edit
puts the edited motion in the player in place of the original, and the statistics, the video and the downloads
follow it through the same chained events as Generate's; Undo goes back one edit, to the very files shown before it.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import gradio as gr

from gesturelsm.backends import SPECS, label
from gesturelsm.errors import GestureError, InputError
from gesturelsm.motion.regions import GENERATED_REGIONS
from gesturelsm.serve.editing import editable
from gesturelsm.serve.request import Result

from .closing import PageClosed, PageWork
from .player import component as motion_player
from .raw_inputs import pass_through

DEFAULT_REGIONS = ["upper", "hands"]
DEFAULT_SECONDS = 2.0              # the range first offered after Generate: this long, from 40 % into the speech
HELP = ("Regenerate the chosen body regions of one motion over a time range from the same speech; everything else "
        "stays exactly as it is. The range shows on the player's timeline; **A/B** on the player swaps the edited "
        "body between the edit and the motion before it. Edits chain; **Undo** goes back one.")
# the range's numbers -> the player's timeline (Gradio runs it in the browser on every change of either)
RANGE_JS = "(a, b) => { if (window.gesturelsmPlayer) window.gesturelsmPlayer.setRange(a, b); }"
PLAYHEAD_JS = "() => (window.gesturelsmPlayer ? window.gesturelsmPlayer.currentTime() : 0)"


@dataclass
class EditControls:
    box: gr.Group
    method: gr.Dropdown
    start: gr.Number
    end: gr.Number
    regions: gr.CheckboxGroup
    seed: gr.Number
    run: gr.Button
    undo: gr.Button
    here: tuple[gr.Button, gr.Button]

    @property
    def inputs(self) -> list:
        return [self.method, self.start, self.end, self.regions, self.seed]


def component() -> EditControls:
    """The section, hidden until a motion is shown."""
    with gr.Group(visible=False, elem_id="edit-box") as box:
        gr.Markdown("**Edit the motion.** " + HELP)
        with gr.Row():
            # every method that can edit, from the start: an API client that ran /generate_motion never runs the
            # private event that narrows them to the shown motions (the handler refuses one that is not shown)
            method = gr.Dropdown([(label(m), m) for m, s in SPECS.items() if s.inpainting], value=None,
                                 label="Motion", elem_id="edit-method", interactive=True)
            start = gr.Number(label="From (s)", minimum=0, precision=2, elem_id="edit-start")
            end = gr.Number(label="To (s)", minimum=0, precision=2, elem_id="edit-end")
            seed = pass_through(gr.Number(value=1, precision=0, minimum=0, label="Seed", elem_id="edit-seed"))
        with gr.Row():
            here = (gr.Button("From: the player's time", size="sm", elem_id="edit-start-here"),
                    gr.Button("To: the player's time", size="sm", elem_id="edit-end-here"))
        regions = gr.CheckboxGroup(list(GENERATED_REGIONS), value=DEFAULT_REGIONS, label="Body regions",
                                   elem_id="edit-regions")
        with gr.Row():
            run = gr.Button("Regenerate", variant="primary", elem_id="edit-run")
            undo = gr.Button("Undo", interactive=False, elem_id="edit-undo")
    return EditControls(box, method, start, end, regions, seed, run, undo, here)


class EditHandlers:
    """The section's events over the page's handlers (their service, their newest-request bookkeeping)."""

    def __init__(self, handlers):
        self.h = handlers

    def ready(self, out: Result | None):
        """After Generate: the section, the motions that can be edited and a first range."""
        able = editable(self.h.service.pipeline, out)
        if not able:
            return gr.update(visible=False), gr.skip(), gr.skip(), gr.skip(), gr.update(interactive=False)
        duration = out.job.speech_seconds
        a = round(min(0.4 * duration, max(0.0, duration - DEFAULT_SECONDS)), 2)
        return (gr.update(visible=True),
                gr.update(choices=[(label(m), m) for m in able], value=able[0]),
                a, round(min(duration, a + DEFAULT_SECONDS), 2), gr.update(interactive=False))

    def run(self, out, method, start, end, regions, seed, character=None, request: gr.Request = None,
            progress=gr.Progress()):
        """Edit the shown motion; the player gets the edited payload (with the motion before it for A/B)."""
        try:
            with self.h.pages.running(request) as closed:      # the tab closed: stop at the next window
                new = self.h.service.edit(out, method, start, end, regions, seed,
                                          progress=PageWork.checked(progress, closed))
        except PageClosed:
            logging.getLogger("gesturelsm.app").info("a page closed during an edit: the edit stopped")
            return gr.skip(), gr.skip(), gr.skip(), gr.skip(), gr.skip()
        except GestureError as exc:
            self.h.refuse(exc)
        self.h.mark_newest(request, new)
        return _resumed(motion_player.payload(self.h.service, new, character)), new.table, new.summary, new, \
            gr.update(interactive=True)

    def undo(self, out, character=None, request: gr.Request = None):
        """Back one edit: the result before it, with its own files (video and downloads when it had them)."""
        if out is None or out.previous is None:
            self.h.refuse(InputError("Nothing to undo: no edit has been made since Generate."))
        prev = out.previous
        self.h.mark_newest(request, prev)
        files, glb = self.h.download_files(prev)
        return (_resumed(motion_player.payload(self.h.service, prev, character)), prev.table, prev.summary, prev,
                str(prev.video) if prev.video else None, files or None,
                gr.update(interactive=prev.previous is not None))


def _resumed(payload: dict | None) -> dict | None:
    """The player keeps its time and play / pause for this payload (the same speech: an edit or an undo)."""
    return None if payload is None else {**payload, "resume": True}


def attach(edit: EditControls, handlers, shown, state, character, outputs: dict, after) -> None:
    """Wire the section: shown after `shown` (Generate's event); Regenerate and Undo return a payload for the player
    (the page hands every new payload to the player, with the statistics), and `after(event)` chains on them what
    follows Generate (video, downloads).
    `outputs`: the page's payload, table, summary, video and files components."""
    e = EditHandlers(handlers)
    shown.then(e.ready, state, [edit.box, edit.method, edit.start, edit.end, edit.undo], api_visibility="private",
               show_progress="hidden")
    for box in (edit.start, edit.end):
        box.change(None, [edit.start, edit.end], None, js=RANGE_JS, api_visibility="private")
    for button, target in zip(edit.here, (edit.start, edit.end)):
        button.click(None, None, target, js=PLAYHEAD_JS, api_visibility="private")
    o = outputs
    ran = edit.run.click(e.run, [state, *edit.inputs, character], [o["payload"], o["table"], o["summary"], state,
                                                                  edit.undo], api_name="edit_motion",
                         concurrency_limit=handlers.service.settings.concurrency, concurrency_id="generation")
    undone = edit.undo.click(e.undo, [state, character], [o["payload"], o["table"], o["summary"], state, o["video"],
                                                          o["files"], edit.undo], api_visibility="private")
    after(ran)
    after(undone)


__all__ = ["EditControls", "EditHandlers", "attach", "component"]
