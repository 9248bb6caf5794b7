"""Each method's motion on the visitor's character as the in-browser player applies it (the page's character payload,
described in gesturelsm/webapp/character.py), and the character's own files for download; no page code here.

    payload = character_payload(character, motions)            # JSON-able: bones, nodes, fps, per-method rotations
    payload = page_character(character, motions, folder, url)  # plus the file the player loads and its key
    files = rig_downloads(character, motions, folder)          # each method's motion in the character's own file
"""
from __future__ import annotations

import base64
import hashlib
import shutil
from pathlib import Path

import numpy as np

from ..body.model import resolve_body
from ..retarget import Character, retarget_motion
from ..retarget.face import channel_weights, morph_channels, morph_weights
from .alive import alive_face_weights
from .glb import continuous_quaternions, matrix_to_quaternion_xyzw
from .rig import export_rig


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
