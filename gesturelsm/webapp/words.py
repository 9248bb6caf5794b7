"""Each upload its own words, and the click that is seen .

Words the page recognised belong to the upload they came from: the page keeps them in a state (`words`:
{"audio": path, "text": recognised}) beside the transcript box. New speech (uploaded, recorded or removed) clears
them from the box (`new_speech`), before the upload's prefetch reads it; words the visitor typed stay, with a visible
note (`layout.TYPED_NOTE`). A request never times one upload with the words recognised for another (`own_words`:
a generation of earlier speech that finished after the new upload may have written them into the box). The status
line under the player (`status`) and the click's scroll (`CLICK_JS`) make Generate visible.
"""
from __future__ import annotations

import logging

import gradio as gr

from .layout import TYPED_NOTE

log = logging.getLogger("gesturelsm.app")

# Runs in the browser as Generate is clicked, before the request: brings the player and the status under it into view
# (the button sits below the fold on a laptop screen).
CLICK_JS = """(...args) => {
    const box = document.querySelector('#motion-player-box');
    if (box) box.scrollIntoView({block: 'start', behavior: 'instant'});
    return args; }"""


def new_speech(text, words):
    """Speech uploaded, recorded or removed: words the page recognised for earlier speech (`words`) are cleared from
    the transcript box; words the visitor typed stay with a visible note. -> (transcript box, note, words state)."""
    typed = (text or "").strip()
    if not typed:
        return gr.skip(), gr.update(value="", visible=False), None
    if words and typed == (words.get("text") or "").strip():
        return "", gr.update(value="", visible=False), None
    return gr.skip(), gr.update(value=TYPED_NOTE, visible=True), words


def own_words(audio, text, words) -> str:
    """The transcript a request of the page uses: the box's words, unless they are the words the page recognised for
    another upload: then none, so this speech is transcribed itself."""
    if text and words and words.get("audio") != audio and text.strip() == (words.get("text") or "").strip():
        log.info("the transcript box held the words recognised for earlier speech: not used for this one")
        return ""
    return text


READY = "**Ready:** motion, video and downloads."      # the status once the request's last step is done


def recognised(audio, out):
    """The words state after a request's result `out` (a serve.request.Result): the words it recognised, with the
    upload they belong to; unchanged (gr.skip) when it recognised none (typed words, a TextGrid, audio-only)."""
    return {"audio": audio, "text": out.transcript} if out.transcript else gr.skip()


def status(out) -> str:
    """The line under the player while a request is made (a serve.request.Result): which methods' bodies are made,
    and what comes next."""
    total = len(out.slots) or len(out.motions)
    made, failed = len(out.motions), len(out.failed)
    if made + failed < total:
        return f"**Generating:** {made} of {total} methods made; each body plays above the moment its motion is made."
    gone = f" ({failed} failed: see its label)" if failed else ""
    return f"**Motion made** for {made} of {total} methods{gone}. Rendering the video and preparing the downloads..."


def changes(inputs: list) -> list:
    """The events after which the page's request may differ: speech uploaded or recorded, the transcript left, a slider
    let go, any other input changed."""
    audio, text = inputs[0], inputs[1]
    events = [audio.upload, audio.stop_recording, text.blur]
    for c in inputs[2:]:
        events.append(c.release if isinstance(c, gr.Slider) else c.change)
    return events


def attach(inputs: list, note, prefetch) -> gr.State:
    """Wire the page's events (call inside `with gr.Blocks()`; `inputs` in ui._Handlers.request order): after each of
    `changes` the upload is prepared with `prefetch` (serve/prepared.py, serve/ahead.py); new speech first clears
    recognised words (`new_speech`), so the prefetch reads the box as the click will; editing the box hides the note.
    Returns the `words` state (the button's handler reads it and writes the words it recognised)."""
    audio, text, words = inputs[0], inputs[1], gr.State()
    ahead = dict(show_progress="hidden", api_visibility="private", concurrency_limit=1, concurrency_id="prefetch",
                 trigger_mode="always_last")
    for changed in changes(inputs):
        if changed in (audio.upload, audio.stop_recording):
            changed(new_speech, [text, words], [text, note, words], queue=False, api_visibility="private",
                    show_progress="hidden") \
                .then(prefetch, [*inputs, words], None, **ahead)
        else:
            changed(prefetch, [*inputs, words], None, **ahead)
    audio.clear(new_speech, [text, words], [text, note, words], queue=False, api_visibility="private",
                show_progress="hidden")
    text.input(lambda: gr.update(visible=False), None, note, queue=False, api_visibility="private")
    return words
