"""The Gradio side of the page's in-browser motion player (the player is `src/` beside this file).

`player_component()` puts the player (element id `motion-player`) in the page; its JavaScript bundle (`dist/player.js`
beside this file, built from `src/` by scripts/setup.sh with npm + esbuild, no CDN, its stylesheet player.css bundled
in) is served by the app itself. `payload(service, outcome)` writes what the player fetches (speech wav, rest-body GLB
once per shape, one motion record per method, gesturelsm/export/motion_codec.py) and returns the JSON the page hands to
`window.gesturelsmPlayer.load(payload)`, the page's one global player API (src/index.js; the Live tab's feed is its
`.live`).
"""
from __future__ import annotations

from pathlib import Path

import gradio as gr

from gesturelsm.constants import SAMPLE_RATE
from gesturelsm.export.player_payload import Shown, Slot, player_payload, rest_body
from gesturelsm.serve.editing import edited_method
from gesturelsm.serve.request import Result
from gesturelsm.request_files import BODIES, SPEECH
from gesturelsm.serve.service import GestureService

from ..character import page_character


BUNDLE = Path(__file__).resolve().parent / "dist" / "player.js"     # in a checkout and in a wheel built with it
ELEMENT = ('<div id="motion-player" data-state="empty" data-frames="0" data-frame="0" data-fps="0" '
           'data-preload="{preload}"></div>')
MISSING = ('<div id="motion-player" data-state="empty" data-frames="0"><p>The in-browser player is not built '
           '(it needs npm once: <code>bash scripts/setup.sh</code>); the video below still comes.</p></div>')
# Gradio runs this with `element` = the component's root; the import resolves against the page's URL, so the
# app also works under a root path (reverse proxy).
MOUNT_JS = "import(new URL('gradio_api/file={bundle}', document.baseURI).href)" \
           ".then((m) => m.mount(element.querySelector('#motion-player')))" \
           ".catch((e) => {{ element.querySelector('#motion-player').dataset.error = String(e); }});"
# The chained event that hands a payload to the player (not awaited: rendering the mp4 starts at once).
LOAD_JS = "(p) => { if (p && window.gesturelsmPlayer) { window.gesturelsmPlayer.load(p); } }"


def file_url(path: Path) -> str:
    """URL (relative to the page) under which the app serves a file it is allowed to serve."""
    return f"gradio_api/file={Path(path).resolve()}"


def served_paths() -> list[str]:
    """Folders `launch(allowed_paths=...)` must include for the player (its bundle)."""
    return [str(BUNDLE.parent)]


def body_url(service: GestureService) -> str:
    """The rest body of the default shape (zero betas, what the generators output), written once."""
    return file_url(rest_body(service.body, service.workdir / BODIES))


def player_component(service: GestureService) -> gr.HTML:
    """The player, or a note saying how to build it when the bundle is missing. The player loads the body of
    the default shape as the page opens."""
    if not BUNDLE.exists():
        return gr.HTML(MISSING, elem_id="motion-player-box")
    return gr.HTML("", html_template=ELEMENT.format(preload=body_url(service)),
                   js_on_load=MOUNT_JS.format(bundle=BUNDLE),
                   elem_id="motion-player-box", padding=False)


def payload(service: GestureService, out: Result, character=None) -> dict | None:
    """Write the player's files for a generated request (its folder) and return the player's payload
    (gesturelsm/export/player_payload.py builds it from `shown(out)`); with a character (gesturelsm/webapp/character.py)
    its `character` entry puts every method made on it (and the edited method's motion before the edit as
    `METHOD:before`); a method being made then shows no motion until it is made."""
    import soundfile as sf

    what = shown(out, previews=character is None)
    if what is None:
        return None
    folder = out.job.folder
    wav = folder / SPEECH
    if not wav.exists():
        sf.write(wav, out.job.audio, SAMPLE_RATE, subtype="PCM_16")
    p = player_payload(what, service.body, folder, service.workdir / BODIES, url=file_url, audio=wav)
    if character is not None:           # from the first payload on: the slots are built on the character
        motions = {s.method: s.motion for s in what.slots if s.motion is not None}
        if what.before is not None:
            motions[f"{what.before[0]}:before"] = what.before[1].slice(0, p["frames"])
        p["character"] = page_character(character, motions, folder, file_url, service.body, out.job.grounding)
    return p


def shown(out: Result, previews: bool = True) -> Shown | None:
    """What the player shows of a result (None: no method at all): for a result that is still growing
    (serve/progressive.py) every method shown, with its motion once it is made, its first windows while it is being
    made (`Result.previews`, on the mannequin; with `previews`) or why it failed; for an edited result the edited
    method's motion before the edit (the player's A/B)."""
    slots = list(out.slots) or list(zip(out.motions, out.job.labels))
    if not slots:
        return None
    labels = {**dict(slots), **dict(zip(out.motions, out.job.labels))}     # an edited motion's label says so
    grown = out.previews if previews else {}
    edited = edited_method(out)
    return Shown(tuple(Slot(m, labels[m], out.motions.get(m), grown.get(m), out.failed.get(m)) for m, _ in slots),
                 out.job.speech_seconds, None if edited is None else (edited, out.previous.motions[edited]))
