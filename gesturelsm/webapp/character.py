"""The visitor's character on the page, server side: the upload (`elem_id="character"`, .vrm / .glb / .gltf)
is read and checked once, each method's motion is retargeted onto it, and the player gets per-bone rotations
to apply with three-vrm (gesturelsm/webapp/player/src/character.js `applyFrame`).

    upload = character_upload()                        # gr.File(elem_id="character") beside the methods
    character = read_upload(path)                      # Character, or gr.Error with one line
    payload = character_payload(character, motions)    # JSON-able: bones, nodes, fps, per-method rotations

The payload per method holds base64 float32 arrays: `quats` (frames, bones, 4), local rotations (x, y, z, w)
of the bone nodes in `nodes` (glTF node indices, hips first; `bones` are their names), and `root` (frames, 3),
the hips' local translation; `align` (x, y, z, w) turns the character's world into the player's (SMPL-X axes)
and `scale` is its units per metre. A VRM that defines viseme (`aa ih ou ee oh`) or `blink` expressions also moves
its face: `morphs` lists the morph-target channels its presets bind, [[glTF mesh index, morph target index], ...],
and each method adds `morph` (frames, len(morphs)), those channels' weights = `retarget.face.morph_weights` of the
method's `alive_face_weights` (what the exported VRM animates); the player sets them as the influences of every three.js
Mesh of that glTF mesh. A character without these presets gets neither key. The player sets
`#motion-player[data-character]` to `name`. A file that cannot be used raises gr.Error (`choose`, the upload's
event: a warning) and the mannequin stays.

    files = rig_downloads(character, motions, folder)  # each method's motion in the character's own file
"""
from __future__ import annotations

import base64
import hashlib
import logging
import shutil
from pathlib import Path

import gradio as gr
import numpy as np

from gesturelsm.body.model import resolve_body
from gesturelsm.errors import GestureError
from gesturelsm.export.glb import continuous_quaternions, matrix_to_quaternion_xyzw
from gesturelsm.export.alive import alive_face_weights
from gesturelsm.export.rig import export_rig
from gesturelsm.retarget import Character, check_usable, load_character, retarget_motion
from gesturelsm.retarget.face import channel_weights, morph_channels, morph_weights
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


def _b64(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a, np.float32).tobytes()).decode()


def bone_order(skel) -> list[int]:
    """The joints the player sets, in the payload's order: the hips, then the other humanoid bones."""
    return [skel.bones["pelvis"]] + sorted(i for i in skel.bones.values() if i != skel.bones["pelvis"])


def face_channels(character: Character) -> list[tuple[int, int]]:
    """The morph-target channels (glTF mesh, target) the character's viseme / blink presets bind; [] for none."""
    return morph_channels(character.document.gltf) if character.document is not None else []


def face_morph(character: Character, channels: list[tuple[int, int]], seq, body, blinker=None) -> np.ndarray:
    """(frames, len(channels)) float32: the weights of `channels` for `seq`'s jaw and expressions (the export's);
    `blinker`: a stream's (its blinks carried over chunks), else the whole motion's own."""
    gltf = character.document.gltf
    per_mesh = morph_weights(gltf, alive_face_weights(body, seq, blinker))
    return channel_weights(per_mesh, channels, seq.num_frames)


def character_payload(character: Character, motions: dict, body=None, grounding: bool = True) -> dict:
    """Each method's motion on the character: {name, bones, nodes, fps, frames, methods: {method: {quats, root}}},
    plus `morphs` and each method's `morph` for a character with face presets (module docstring); its feet
    planted on its own legs unless `grounding` is off."""
    skel = character.skeleton
    order = bone_order(skel)
    out = {"name": character.name, "bones": [skel.names[i] for i in order], "nodes": [skel.nodes[i] for i in order],
           "methods": {}}
    channels = face_channels(character)
    if channels:
        out["morphs"] = [list(c) for c in channels]
        face_body = resolve_body(body)
    for method, seq in motions.items():
        r = retarget_motion(seq, character, body, grounding=grounding)
        q = continuous_quaternions(matrix_to_quaternion_xyzw(r.local_rotation[:, order]))
        out["methods"][method] = {"quats": _b64(q), "root": _b64(r.root_translation)}
        if channels:
            out["methods"][method]["morph"] = _b64(face_morph(character, channels, seq, face_body))
        out["fps"], out["frames"] = r.fps, min(out.get("frames", r.num_frames), r.num_frames)
        out["align"] = matrix_to_quaternion_xyzw(r.align).tolist()
        out["scale"] = float(r.scale)
    out["head"] = order.index(skel.bones["head"]) if "head" in skel.bones else 0
    return out


def page_character(character: Character, motions: dict, folder: Path, url, body=None, grounding: bool = True) -> dict:
    """`character_payload` plus the file the player loads: copied into the request's folder (`url(path)` is its
    address) and `key`, a hash of its bytes, so the browser parses one character once whatever the request."""
    data = character.path.read_bytes()
    path = Path(folder) / f"character{character.path.suffix.lower()}"
    shutil.copyfile(character.path, path)
    return {**character_payload(character, motions, body, grounding), "url": url(path),
            "key": hashlib.sha1(data).hexdigest()}


def rig_downloads(character: Character | None, motions: dict, folder: Path, body=None,
                  grounding: bool = True) -> list[Path]:
    """Each method's motion in the character's own file (`gesturelsm export --rig`): METHOD_NAME.vrm / .glb."""
    if character is None:
        return []
    return [export_rig(seq, character, Path(folder) / f"{method}.npz", body, grounding)
            for method, seq in motions.items()]


def decode(b64: str, shape: tuple[int, ...]) -> np.ndarray:
    """A payload array back to numpy (for tests and tools)."""
    return np.frombuffer(base64.b64decode(b64), np.float32).reshape(shape)
