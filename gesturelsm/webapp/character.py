"""The visitor's character on the page, server side: the upload (`elem_id="character"`, .vrm / .glb / .gltf)
is read and checked once, each method's motion is retargeted onto it, and the player gets per-bone rotations
to apply with three-vrm (app/player/src/character.js `applyFrame`).

    upload = character_upload()                        # gr.File(elem_id="character") beside the methods
    character = read_upload(path)                      # Character, or gr.Error with one line
    payload = character_payload(character, motions)    # JSON-able: bones, nodes, fps, per-method rotations

The payload per method holds base64 float32 arrays: `quats` (frames, bones, 4), local rotations (x, y, z, w)
of the bone nodes in `nodes` (glTF node indices, hips first; `bones` are their names), and `root` (frames, 3),
the hips' local translation. The player sets `#motion-player[data-character]` to `name`. A file that cannot
be used raises gr.Error and the mannequin stays.
"""
from __future__ import annotations

import base64
from pathlib import Path

import gradio as gr
import numpy as np

from gesturelsm.errors import GestureError
from gesturelsm.export.glb import continuous_quaternions, matrix_to_quaternion_xyzw
from gesturelsm.retarget import Character, load_character, retarget_motion

MAX_CHARACTER_BYTES = 32 * 1024 * 1024        # a page upload; the CLI takes up to 64 MB
PAGE_SUFFIXES = (".vrm", ".glb", ".gltf")


def character_upload() -> gr.File:
    """The Character upload shown beside the methods."""
    return gr.File(label="Character (.vrm / .glb / .gltf, optional)", file_types=list(PAGE_SUFFIXES),
                   elem_id="character")


def read_upload(path: str | Path | None) -> Character | None:
    """The uploaded character, None when nothing was uploaded; a file that cannot be used -> gr.Error."""
    if not path:
        return None
    path = Path(path)
    if path.suffix.lower() not in PAGE_SUFFIXES:
        raise gr.Error(f"{path.name}: a character must be a .vrm, .glb or .gltf file", print_exception=False)
    try:
        character = load_character(path, limit=MAX_CHARACTER_BYTES)
    except GestureError as exc:
        raise gr.Error(str(exc), print_exception=False) from None
    if character.document is None or (character.document.gltf.get("buffers") and not character.document.blob):
        raise gr.Error(f"{path.name}: its buffers are separate files; upload a .glb or .vrm",
                       print_exception=False)
    return character


def _b64(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a, np.float32).tobytes()).decode()


def character_payload(character: Character, motions: dict, body=None) -> dict:
    """Each method's motion on the character: {name, bones, nodes, fps, frames, methods: {method: {quats, root}}}."""
    skel = character.skeleton
    order = [skel.bones["pelvis"]] + sorted(i for i in skel.bones.values() if i != skel.bones["pelvis"])
    out = {"name": character.name, "bones": [skel.names[i] for i in order], "nodes": [skel.nodes[i] for i in order],
           "methods": {}}
    for method, seq in motions.items():
        r = retarget_motion(seq, character, body)
        q = continuous_quaternions(matrix_to_quaternion_xyzw(r.local_rotation[:, order]))
        out["methods"][method] = {"quats": _b64(q), "root": _b64(r.root_translation)}
        out["fps"], out["frames"] = r.fps, r.num_frames
    return out


def decode(b64: str, shape: tuple[int, ...]) -> np.ndarray:
    """A payload array back to numpy (for tests and tools)."""
    return np.frombuffer(base64.b64decode(b64), np.float32).reshape(shape)
