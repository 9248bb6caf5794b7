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
from gesturelsm.export.player_payload import body_glb, player_payload, write_motion
from gesturelsm.motion.sequence import NUM_BETAS
from gesturelsm.serve.editing import edited_method
from gesturelsm.serve.request import Result
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


def player_component(service: GestureService) -> gr.HTML:
    """The player, or a note saying how to build it when the bundle is missing. The player loads the body of
    the default shape (zero betas, what the generators output) as the page opens."""
    import numpy as np

    if not BUNDLE.exists():
        return gr.HTML(MISSING, elem_id="motion-player-box")
    body = file_url(body_glb(service.body, np.zeros(NUM_BETAS, np.float32), service.workdir / "player-bodies"))
    return gr.HTML("", html_template=ELEMENT.format(preload=body), js_on_load=MOUNT_JS.format(bundle=BUNDLE),
                   elem_id="motion-player-box", padding=False)


def payload(service: GestureService, out: Result, character=None) -> dict | None:
    """Write the player's files for a generated request (its folder) and return the player's payload; with a
    character (gesturelsm/webapp/character.py) its `character` entry puts every method on it. For an edited result,
    `compare` is the edited method's motion before the edit (the player's A/B), beside the character's `METHOD:before`."""
    import soundfile as sf

    if not out.motions:
        return None
    folder = out.job.folder
    wav = folder / "speech.wav"
    sf.write(wav, out.job.audio, SAMPLE_RATE, subtype="PCM_16")
    p = player_payload(list(out.motions.values()), list(out.job.labels), list(out.motions), service.body, folder,
                       service.workdir / "player-bodies", url=file_url, audio=wav)
    motions, edited = dict(out.motions), edited_method(out)
    if edited is not None:
        i, before = list(out.motions).index(edited), out.previous.motions[edited].slice(0, p["frames"])
        path, _ = write_motion(before, service.body, folder / f"player-{i}-{edited}-before.bin")
        p["compare"] = {"index": i, "method": edited, "motion": file_url(path)}
        motions[f"{edited}:before"] = before
    if character is not None:
        p["character"] = page_character(character, motions, folder, file_url, service.body, out.job.grounding)
    return p
