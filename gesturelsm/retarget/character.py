"""One entry point for a character file: `load_character(path)` -> Character (skeleton, and for glTF / VRM
the document the animated GLB is written into), `retarget_motion(seq, character)` -> Retargeted, its feet planted
on the character's own legs unless `grounding=False`."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..body.model import resolve_body
from .bvh_read import read_bvh_skeleton
from .errors import CharacterError
from .gltf import GltfDocument, gltf_skeleton, read_gltf
from .limits import MAX_BYTES
from .mesh import character_mesh, has_mesh
from .grounding import ground_retargeted
from .skeleton import Skeleton
from .solve import Ground, Retargeted, SourceBody, prepare, retarget

SUFFIXES = (".vrm", ".glb", ".gltf", ".bvh")


@dataclass
class Character:
    path: Path
    skeleton: Skeleton
    document: GltfDocument | None = None      # None for a BVH skeleton

    @property
    def name(self) -> str:
        return self.path.name


def load_character(path: str | Path, bone_map: str | dict | None = None, limit: int = MAX_BYTES) -> Character:
    """A .vrm / .glb / .gltf / .bvh file -> Character. bone_map: None (VRM humanoid map or the best-fitting
    preset), "mixamo", "smplx", a JSON file {SMPL-X joint: bone name}, or such a dict."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES:
        raise CharacterError(f"{path.name}: not a character file; use a .vrm, .glb, .gltf or .bvh")
    if suffix == ".bvh":
        return Character(path, read_bvh_skeleton(path, bone_map, limit=limit))
    doc = read_gltf(path, limit)
    return Character(path, gltf_skeleton(doc, bone_map), doc)


def check_usable(character: Character, body=None, draw: bool = True) -> None:
    """CharacterError at once for what would otherwise fail later, on every use of the character: its rest pose
    cannot be retargeted (an absurd scale, hips and head in one place), or (draw=True: it will be drawn) the meshes
    a video draws break the limits or hold NaN (their geometry is decoded and dropped; textures are not decoded, a
    bad one only becomes a note when drawn). The page runs it once per upload, `batch --rig` and `generate --rig`
    before their work."""
    prepare(character.skeleton, SourceBody.of(resolve_body(body)))
    if draw and has_mesh(character.document):
        character_mesh(character.document, character.skeleton, textures=False)


def retarget_motion(seq, character: Character | Skeleton, body=None, ground: Ground | None = None,
                    grounding: bool = True) -> Retargeted:
    """`seq` (MotionSequence on `body`: None = $GESTURELSM_SMPLX_MODEL or the mannequin) on the character;
    `ground`: the root motion's reference (solve.py `Ground`; None: the motion's own first frame and floor);
    `grounding`: its feet planted on its own legs (grounding.py; `note` says why not when they cannot be)."""
    skel = character.skeleton if isinstance(character, Character) else character
    source = SourceBody.of(resolve_body(body), seq.betas)
    setup = prepare(skel, source)
    result = retarget(seq, skel, source, ground, setup)
    return ground_retargeted(result, setup) if grounding else result
