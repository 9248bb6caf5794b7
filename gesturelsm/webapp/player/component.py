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
from gesturelsm.request_files import BODIES, SPEECH, player_before, player_file, player_partial
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
    import numpy as np

    return file_url(body_glb(service.body, np.zeros(NUM_BETAS, np.float32), service.workdir / BODIES))


def player_component(service: GestureService) -> gr.HTML:
    """The player, or a note saying how to build it when the bundle is missing. The player loads the body of
    the default shape as the page opens."""
    if not BUNDLE.exists():
        return gr.HTML(MISSING, elem_id="motion-player-box")
    return gr.HTML("", html_template=ELEMENT.format(preload=body_url(service)),
                   js_on_load=MOUNT_JS.format(bundle=BUNDLE),
                   elem_id="motion-player-box", padding=False)


def payload(service: GestureService, out: Result, character=None) -> dict | None:
    """Write the player's files for a generated request (its folder) and return the player's payload; with a
    character (gesturelsm/webapp/character.py) its `character` entry puts every method on it. For a result that is
    still growing (serve/progressive.py) every method shown has a body entry, with its motion file once it is made
    (`motion`) or why it failed (`error`); files already written for the request are not written again. For an
    edited result, `compare` is the edited method's motion before the edit (the player's A/B), beside the
    character's `METHOD:before`. A method still being made whose first windows are decoded (`Result.previews`, on the
    mannequin) has a body entry with `partial` set and the motion so far (`frames` of them), replaced by its finished
    motion once it is made."""
    import soundfile as sf

    slots = list(out.slots) or list(zip(out.motions, out.job.labels))
    if not slots:
        return None
    folder = out.job.folder
    wav = folder / SPEECH
    if not wav.exists():
        sf.write(wav, out.job.audio, SAMPLE_RATE, subtype="PCM_16")
    order = [m for m, _ in slots]
    made = [m for m in order if m in out.motions]
    labels = {**dict(slots), **dict(zip(out.motions, out.job.labels))}     # an edited motion's label says so
    p = player_payload([out.motions[m] for m in made], [labels[m] for m in made], made, service.body, folder,
                       service.workdir / BODIES, url=file_url, audio=wav,
                       names=[player_file(order.index(k), k) for k in made])
    ready = {b["method"]: b for b in p["bodies"]}
    rest = body_url(service)
    growing = {} if character is not None else previews(service, out, folder, order)
    p["bodies"] = [ready.get(m) or growing.get(m) or {"label": label, "method": m, "body": rest, "motion": None,
                                                      "expressions": 0,
                                                      **({"error": out.failed[m]} if m in out.failed else {})}
                   for m, label in slots]
    p["frames"] = p["frames"] or int(round(out.job.speech_seconds * p["fps"]))
    p["duration"] = p["frames"] / p["fps"]
    motions, edited = {m: out.motions[m] for m in made}, edited_method(out)
    if edited is not None:
        i, before = order.index(edited), out.previous.motions[edited].slice(0, p["frames"])
        path, _ = write_motion(before, service.body, folder / player_before(i, edited))
        p["compare"] = {"index": i, "method": edited, "motion": file_url(path)}
        motions[f"{edited}:before"] = before
    if character is not None:           # from the first payload on: the slots are built on the character
        p["character"] = page_character(character, motions, folder, file_url, service.body, out.job.grounding)
    return p


def previews(service: GestureService, out: Result, folder: Path, order: list[str]) -> dict[str, dict]:
    """Body entries of the methods still being made whose raw first windows the result holds: each preview written
    once (player-I-METHOD-upto-FRAMES.bin) and marked `partial`."""
    bodies = {}
    for m, seq in out.previews.items():
        if m in out.motions or m not in order:
            continue
        i = order.index(m)
        path = folder / player_partial(i, m, seq.num_frames)
        p = player_payload([seq], [dict(out.slots).get(m, m)], [m], service.body, folder,
                           service.workdir / BODIES, url=file_url, names=[path.name])
        bodies[m] = {**p["bodies"][0], "partial": True, "frames": seq.num_frames}
    return bodies
