"""Exports of a motion on the user's character: the character's own file with the motion added (GLB; a VRM
stays a VRM: every extension is kept and the motion is a glTF animation on its bone nodes), or its skeleton
as BVH; either with the feet planted on the character's own legs (retarget/grounding.py) unless `grounding` is off.

    character = load_character("avatar.vrm")
    export_rig_glb(seq, character, "avatar_take.vrm")   # or .glb
    export_rig_bvh(seq, character, "avatar_take.bvh")
"""
from __future__ import annotations

import copy
from pathlib import Path

import numpy as np

from ..retarget import Character, CharacterError, Retargeted, retarget_motion
from ..body.model import resolve_body
from ..retarget.face import driven_presets, morph_weights
from .alive import alive_face_weights
from .bvh import continuous_euler, matrix_to_euler_zxy
from .glb import FLOAT, GltfBuffer, continuous_quaternions, matrix_to_quaternion_xyzw, write_glb
from .guard import animation_times, check_motion, check_rate, finite


def _face_channels(b: GltfBuffer, gltf: dict, seq, a_time: int, body) -> list[tuple[dict, dict]]:
    """Morph-weight channels for the VRM presets the character defines (visemes and blink, `retarget.face`, with the
    mouth and blinks of `alive.py`), one
    per mesh node that a driven preset binds; no channel when the character defines none of them."""
    presets = driven_presets(gltf)
    if not presets:
        return []
    weights = alive_face_weights(resolve_body(body), seq)
    per_mesh = morph_weights(gltf, {p: weights[p] for p in presets})
    out = []
    for n, node in enumerate(gltf.get("nodes", [])):
        W = per_mesh.get(node.get("mesh"))
        if W is None or W.shape[1] == 0:
            continue
        out.append(({"input": a_time, "output": b.add(W.astype(np.float32).reshape(-1), FLOAT, "SCALAR"),
                     "interpolation": "LINEAR"}, {"target": {"node": n, "path": "weights"}}))
    return out


def export_rig_glb(seq, character: Character, path: str | Path, body=None,
                   result: Retargeted | None = None, name: str = "gesturelsm", grounding: bool = True) -> Path:
    """The character's file plus an animation `name`: rotations of its humanoid bones, the hips'
    translation and, for a VRM with viseme (`aa`, `ih`, `ou`, `ee`, `oh`) or `blink` expressions, their morph
    targets' weights from the generated face (`retarget.face`). `result`: the motion retargeted already, else
    retargeted here with its feet planted on the character's legs unless `grounding` is off. Returns the path."""
    check_motion(seq)
    if character.document is None:
        raise CharacterError(f"{character.name}: a BVH skeleton has no mesh; export it with --bvh")
    doc = character.document
    if doc.gltf.get("buffers") and not doc.blob:
        raise CharacterError(f"{character.name}: its buffers are separate files; save it as .glb or .vrm first")
    for img in doc.gltf.get("images", []):
        if "uri" in img and not str(img["uri"]).startswith("data:"):
            raise CharacterError(f"{character.name}: its textures are separate files; save it as .glb or .vrm")
    r = result if result is not None else retarget_motion(seq, character, body, grounding=grounding)
    skel = r.skeleton
    gltf = copy.deepcopy(doc.gltf)
    b = GltfBuffer.after(gltf, doc.blob)   # the character's own data first
    T = r.num_frames
    a_time = b.add(animation_times(T, r.fps, "the retargeted motion"), FLOAT, "SCALAR", minmax=True)
    quats = continuous_quaternions(matrix_to_quaternion_xyzw(r.local_rotation)).astype(np.float32)
    samplers, channels = [], []

    def channel(sampler: dict, target: dict) -> None:
        samplers.append(sampler)
        channels.append({"sampler": len(samplers) - 1, **target})

    for i in sorted(skel.bones.values()):
        channel({"input": a_time, "output": b.add(np.ascontiguousarray(quats[:, i]), FLOAT, "VEC4"),
                 "interpolation": "LINEAR"}, {"target": {"node": skel.nodes[i], "path": "rotation"}})
    channel({"input": a_time, "output": b.add(r.root_translation.astype(np.float32), FLOAT, "VEC3"),
             "interpolation": "LINEAR"}, {"target": {"node": skel.nodes[r.root], "path": "translation"}})
    for sampler, target in _face_channels(b, gltf, seq, a_time, body):
        channel(sampler, target)
    gltf["animations"] = [{"name": name, "samplers": samplers, "channels": channels}] + \
        [a for a in gltf.get("animations", []) if a.get("name") != name]
    buffer = {k: v for k, v in (gltf.get("buffers") or [{}])[0].items() if k != "uri"}
    buffer["byteLength"] = len(b.blob)
    gltf["buffers"] = [buffer] + list(gltf.get("buffers", [])[1:])
    path = Path(path)
    write_glb(path, gltf, b.blob)
    return path


def export_rig_bvh(seq, character: Character, path: str | Path, body=None,
                   result: Retargeted | None = None, grounding: bool = True) -> Path:
    """The character's skeleton below (and including) its hips as BVH, in the character's own axes and
    units: rest frames aligned with its world, so each joint's rotation is Δ_parent^-1 Δ_joint (ZXY Euler,
    continuous); the root's position is the hips' world position. `result` and `grounding` as `export_rig_glb`."""
    check_motion(seq)
    r = result if result is not None else retarget_motion(seq, character, body, grounding=grounding)
    check_rate(r.fps, "the retargeted motion")
    skel = r.skeleton
    rest = skel.world()[:, :3, 3]
    root = r.root
    kids: dict[int, list[int]] = {i: [] for i in range(len(skel))}
    for i, p in enumerate(skel.parents):
        if p >= 0:
            kids[int(p)].append(i)
    D = r.delta                                                                      # (T, N, 3, 3)
    rel = np.swapaxes(D[:, skel.parents], -1, -2) @ D
    rel[:, root] = D[:, root]
    eul = np.degrees(continuous_euler(matrix_to_euler_zxy(rel)))
    lines, order = ["HIERARCHY"], []

    def write(i: int, depth: int) -> None:
        ind = "\t" * depth
        off = np.zeros(3) if i == root else rest[i] - rest[skel.parents[i]]
        lines.extend([f"{ind}{'ROOT' if i == root else 'JOINT'} {skel.names[i].replace(' ', '_')}", f"{ind}{{",
                      f"{ind}\tOFFSET {off[0]:.6f} {off[1]:.6f} {off[2]:.6f}"])
        chans = (["Xposition", "Yposition", "Zposition"] if i == root else []) + \
            ["Zrotation", "Xrotation", "Yrotation"]
        lines.append(f"{ind}\tCHANNELS {len(chans)} {' '.join(chans)}")
        order.append(i)
        for c in kids[i]:
            write(c, depth + 1)
        if not kids[i]:
            e = 0.5 * off
            lines.extend([f"{ind}\tEnd Site", f"{ind}\t{{", f"{ind}\t\tOFFSET {e[0]:.6f} {e[1]:.6f} {e[2]:.6f}",
                          f"{ind}\t}}"])
        lines.append(f"{ind}}}")

    write(root, 0)
    T = r.num_frames
    data = np.concatenate([r.positions[:, root], eul[:, order].reshape(T, -1)], 1)
    finite(data, "the retargeted motion's channels")
    lines += ["MOTION", f"Frames: {T}", f"Frame Time: {1.0 / r.fps:.7f}"]
    body_text = "\n".join(" ".join(f"{x:.6f}" for x in row) for row in data)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n" + body_text + "\n")
    return path


def export_rig(seq, character: Character, beside: str | Path, body=None, grounding: bool = True) -> Path:
    """The motion on the character next to `beside` (e.g. the motion's .npz): STEM_CHARACTER.vrm for a VRM,
    .glb for a glTF, .bvh for a BVH skeleton, its feet planted on the character's legs unless `grounding` is off.
    Returns the path written."""
    beside = Path(beside)
    if character.document is None:
        suffix = ".bvh"
    else:
        suffix = ".vrm" if character.skeleton.kind.startswith("vrm") else ".glb"
    path = beside.with_name(f"{beside.stem}_{character.path.stem}{suffix}")
    if suffix == ".bvh":
        return export_rig_bvh(seq, character, path, body, grounding=grounding)
    return export_rig_glb(seq, character, path, body, grounding=grounding)
