"""The visitor's character on the page, server side: the upload (`elem_id="character"`, .vrm / .glb / .gltf)
is read and checked once, each method's motion is retargeted onto it, and the player gets per-bone rotations
to apply with three-vrm (gesturelsm/webapp/player/src/character.js `applyFrame`).

    upload = character_upload()                        # gr.File(elem_id="character") beside the methods
    character = read_upload(path)                      # Character, or gr.Error with one line
    payload = character_payload(character, motions)    # JSON-able: bones, nodes, fps, per-method rotations

The payload is built without page code in gesturelsm/export/character_payload.py (the live stream's characters use
it too, gesturelsm/live/characters.py). The payload per method holds base64 float32 arrays: `quats` (frames, bones,
4), local rotations (x, y, z, w) of the bone nodes in `nodes` (glTF node indices, hips first; `bones` are their
names), and `root` (frames, 3), the hips' local translation; `align` (x, y, z, w) turns the character's world into
the player's (SMPL-X axes) and `scale` is its units per metre. A VRM that defines viseme (`aa ih ou ee oh`) or
`blink` expressions also moves its face: `morphs` lists the morph-target channels its presets bind, [[glTF mesh
index, morph target index], ...], and each method adds `morph` (frames, len(morphs)), those channels' weights =
`retarget.face.morph_weights` of the method's `alive_face_weights` (what the exported VRM animates); the player sets
them as the influences of every three.js Mesh of that glTF mesh. A character without these presets gets neither key.
The player sets `#motion-player[data-character]` to `name`. A file that cannot be used raises gr.Error (`choose`,
the upload's event: a warning) and the mannequin stays.

    files = rig_downloads(character, motions, folder)  # each method's motion in the character's own file
"""
from __future__ import annotations

import logging
from pathlib import Path

import gradio as gr

from gesturelsm.errors import GestureError
from gesturelsm.export.character_payload import (bone_order, character_payload, decode, face_channels, face_morph,
                                                 page_character, rig_downloads)
from gesturelsm.retarget import Character, check_usable, load_character
from gesturelsm.retarget.grounding import leg_problem

log = logging.getLogger(__name__)
MAX_CHARACTER_BYTES = 32 * 1024 * 1024        # a page upload; the CLI takes up to 64 MB
PAGE_SUFFIXES = (".vrm", ".glb", ".gltf")


LABEL = "Character (.vrm / .glb / .gltf, optional): every method is shown on it instead of the mannequin"


def character_upload() -> gr.File:
    """The Character upload shown beside the methods."""
    return gr.File(label=LABEL, file_types=list(PAGE_SUFFIXES), elem_id="character")


def read_upload(path: str | Path | None) -> Character | None:
    """The uploaded character, None when nothing was uploaded; a file that cannot be used -> gr.Error."""
    if not path:
        return None
    path = Path(path)
    if path.suffix.lower() not in PAGE_SUFFIXES:
        raise gr.Error(f"{path.name}: a character must be a .vrm, .glb or .gltf file", print_exception=False)
    try:
        character = load_character(path, limit=MAX_CHARACTER_BYTES)
        gltf = character.document.gltf if character.document is not None else {}
        if character.document is None or (gltf.get("buffers") and not character.document.blob) or any(
                "uri" in im and not str(im["uri"]).startswith("data:") for im in gltf.get("images", [])):
            raise gr.Error(f"{path.name}: its buffers or textures are separate files; upload a .glb or .vrm",
                           print_exception=False)
        check_usable(character)               # what a later Generate would refuse is refused here, once
    except GestureError as exc:
        raise gr.Error(str(exc), print_exception=False) from None
    return character


def choose(path: str | Path | None) -> tuple[Character | None, dict]:
    """The upload's change event: (the page session's character, the upload's update: its label says what was
    loaded). A file that cannot be used gives a warning with its one-line reason, the mannequin (None) and an
    emptied upload; a character whose legs cannot be grounded is used, with a warning saying so."""
    try:
        character = read_upload(path)
    except gr.Error as exc:
        gr.Warning(exc.message)
        return None, gr.update(value=None, label=LABEL)
    except Exception:                       # a bug: logged with its traceback; the visitor still gets a line
        log.exception("reading an uploaded character failed")
        gr.Warning(f"{Path(path).name}: this file could not be read (an unexpected error, logged on the server); "
                   "the mannequin stays")
        return None, gr.update(value=None, label=LABEL)
    if character is None:
        return None, gr.update(label=LABEL)
    note = leg_problem(character.skeleton)
    if note:
        gr.Warning(note)
    return character, gr.update(label=f"Character: {character.name} ({len(character.skeleton.bones)} humanoid "
                                      f"bones); clear it for the mannequin")


__all__ = ["LABEL", "MAX_CHARACTER_BYTES", "PAGE_SUFFIXES", "bone_order", "character_payload", "character_upload",
           "choose", "decode", "face_channels", "face_morph", "page_character", "read_upload", "rig_downloads"]
