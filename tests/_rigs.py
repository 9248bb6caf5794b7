"""Characters the retargeting tests build themselves from the SMPL-X rest skeleton: other rest poses (A pose,
bent elbows), bone lengths, per-joint local axes, Z-up centimetre worlds, no fingers, a 2-segment spine; and an
independent check of a retargeted motion (forward kinematics from the written local rotations).
"""
from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Iterator

import numpy as np
from scipy.spatial.transform import Rotation

from gesturelsm.export.bvh import euler_zxy_to_matrix
from gesturelsm.motion.skeleton import JOINT_INDEX, JOINT_NAMES, PARENTS
from gesturelsm.retarget.bvh_read import parse_hierarchy
from gesturelsm.retarget.names import MIXAMO, preset_map
from gesturelsm.retarget.skeleton import Skeleton, trs_matrix

FINGERS = tuple(n for n in JOINT_NAMES if any(f in n for f in ("index", "middle", "ring", "pinky", "thumb")))
Y_UP_TO_Z_UP = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])       # (x, y, z) -> (x, -z, y)


def _subtree(j: int) -> list[int]:
    out = [j]
    for c in range(len(PARENTS)):
        if PARENTS[c] in out and c not in out:
            out.append(c)
    return out


def build_rig(J: np.ndarray, *, apose: float = 0.0, elbow: float = 0.0, lengths: float = 0.0,
              axes: bool = False, world: np.ndarray | None = None, units: float = 1.0,
              fingers: bool = True, spine: int = 3, seed: int = 0) -> tuple[Skeleton, np.ndarray]:
    """A Mixamo-named skeleton from SMPL-X rest joints J (55, 3). Returns it and the rotation taking its
    world to SMPL-X's (the test's own oracle for directions).

    apose: arms lowered by this many degrees at the shoulders; elbow: elbows bent (degrees, forward);
    lengths: each bone's length scaled by 1 +- this (random); axes: every joint gets a random local frame;
    world: rotation SMPL-X world -> the rig's world (e.g. Y_UP_TO_Z_UP); units: world units per metre;
    fingers: keep the 30 finger joints; spine: 3 or 2 (drops spine2) segments."""
    rng = np.random.default_rng(seed)
    p = np.asarray(J, np.float64).copy()
    for side, sign in (("left", 1.0), ("right", -1.0)):
        if apose:
            s = JOINT_INDEX[f"{side}_shoulder"]
            R = Rotation.from_rotvec([0, 0, -sign * np.radians(apose)]).as_matrix()
            idx = _subtree(s)[1:]
            p[idx] = (p[idx] - p[s]) @ R.T + p[s]
        if elbow:
            e = JOINT_INDEX[f"{side}_elbow"]
            R = Rotation.from_rotvec([0, sign * np.radians(elbow), 0]).as_matrix()
            idx = _subtree(e)[1:]
            p[idx] = (p[idx] - p[e]) @ R.T + p[e]
    keep = [j for j in range(len(JOINT_NAMES)) if JOINT_NAMES[j] not in ("jaw", "left_eye_smplhf",
                                                                          "right_eye_smplhf")]
    if not fingers:
        keep = [j for j in keep if JOINT_NAMES[j] not in FINGERS]
    if spine == 2:
        keep = [j for j in keep if JOINT_NAMES[j] != "spine2"]
    kept = set(keep)

    def parent(j: int) -> int:
        q = PARENTS[j]
        while q >= 0 and q not in kept:
            q = PARENTS[q]
        return q

    # bone lengths: rebuild positions parent-first with scaled offsets
    pos = {}
    for j in keep:
        q = parent(j)
        f = 1.0 + lengths * rng.uniform(-1, 1) if lengths else 1.0
        pos[j] = p[j] if q < 0 else pos[q] + f * (p[j] - p[q])
    Wr = np.eye(3) if world is None else np.asarray(world, np.float64)
    wpos = {j: units * (Wr @ pos[j]) for j in keep}
    rot = {j: Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix() if axes else Wr
           for j in keep}
    names, parents, t, R = [], [], [], []
    index = {}
    for j in keep:
        q = parent(j)
        index[j] = len(names)
        name = MIXAMO.get(JOINT_NAMES[j], JOINT_NAMES[j])
        if spine == 2 and JOINT_NAMES[j] == "spine3":
            name = "Spine1"
        names.append(name)
        parents.append(index[q] if q >= 0 else -1)
        if q < 0:
            t.append(wpos[j])
            R.append(rot[j])
        else:
            t.append(rot[q].T @ (wpos[j] - wpos[q]))
            R.append(rot[q].T @ rot[j])
    bones = {k: names.index(v) for k, v in preset_map("mixamo", names).items()}
    skel = Skeleton(names=names, parents=np.array(parents), translation=np.array(t), rotation=np.array(R),
                    scale=np.ones((len(names), 3)), bones=bones, source="built rig", kind="gltf")
    return skel, Wr.T


def posed_world(result) -> np.ndarray:
    """(T, N, 3) joint positions by forward kinematics of the retargeted local rotations and the root's
    translation through the skeleton's own rest transforms (independent of the solver's positions)."""
    skel = result.skeleton
    T, N = result.num_frames, len(skel)
    M = np.empty((T, N, 4, 4))
    for i in range(N):
        t = np.broadcast_to(skel.translation[i], (T, 3)).copy()
        if i == result.root:
            t = result.root_translation
        L = np.zeros((T, 4, 4))
        L[:, :3, :3] = result.local_rotation[:, i] * skel.scale[i][None, None, :]
        L[:, :3, 3] = t
        L[:, 3, 3] = 1
        p = skel.parents[i]
        M[:, i] = (skel.base if p < 0 else M[:, p]) @ L
    return M[..., :3, 3]


# the humanoid's limbs, root to tip: a bone runs from a mapped joint to the next mapped joint of its limb
LIMBS = [("pelvis", "spine1", "spine2", "spine3", "neck", "head")] + [
    tuple(f"{s}_{j}" for j in chain) for s in ("left", "right") for chain in (
        ("hip", "knee", "ankle", "foot"), ("collar", "shoulder", "elbow", "wrist", "middle1", "middle2", "middle3"),
        ("index1", "index2", "index3"), ("ring1", "ring2", "ring3"), ("pinky1", "pinky2", "pinky3"),
        ("thumb1", "thumb2", "thumb3"))]


def bones_of(mapped) -> list[tuple[str, str]]:
    """(joint, next joint) along each limb, over the SMPL-X joints a character has."""
    out = []
    for limb in LIMBS:
        present = [j for j in limb if j in mapped]
        out += list(zip(present[:-1], present[1:]))
    return out


def direction_errors(result, to_smplx: np.ndarray, smplx_joints: np.ndarray) -> np.ndarray:
    """Degrees between each mapped bone's world direction on the character and the same bone on SMPL-X,
    (T, bones). smplx_joints: (T, 55, 3) posed SMPL-X joints; to_smplx: the character's world -> SMPL-X's."""
    skel = result.skeleton
    X = posed_world(result) @ to_smplx.T
    errs = []
    for a, c in bones_of(skel.bones):
        u = X[:, skel.bones[c]] - X[:, skel.bones[a]]
        v = smplx_joints[:, JOINT_INDEX[c]] - smplx_joints[:, JOINT_INDEX[a]]
        cos = (u * v).sum(-1) / (np.linalg.norm(u, axis=-1) * np.linalg.norm(v, axis=-1))
        errs.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return np.stack(errs, 1)


__all__ = ["FINGERS", "Y_UP_TO_Z_UP", "build_rig", "direction_errors", "posed_world", "trs_matrix"]


def vrm_body_bones() -> dict[str, str]:
    """VRM humanoid bone -> node name of `build_rig`'s (Mixamo-named) skeleton, body only (no fingers)."""
    human = {"hips": "Hips", "spine": "Spine", "chest": "Spine1", "upperChest": "Spine2", "neck": "Neck",
             "head": "Head"}
    for s, S in (("left", "Left"), ("right", "Right")):
        human.update({f"{s}UpperLeg": f"{S}UpLeg", f"{s}LowerLeg": f"{S}Leg", f"{s}Foot": f"{S}Foot",
                      f"{s}UpperArm": f"{S}Arm", f"{s}LowerArm": f"{S}ForeArm", f"{s}Hand": f"{S}Hand"})
    return human


def write_gltf(skel: Skeleton, path, humanoid: dict[str, str] | None = None, vrm: str = "1",
               names: list[str] | None = None) -> dict:
    """A .glb of the skeleton: one node per joint (its rest TRS), a skin over all of them, no mesh; with
    `humanoid` ({VRM bone: joint name}) a VRM 1.0 (`vrm="1"`) or 0.x (`"0"`) humanoid map. Returns the JSON."""
    import json
    import struct

    names = names or skel.names
    nodes = []
    for i in range(len(skel)):
        node = {"name": names[i], "translation": [float(x) for x in skel.translation[i]],
                "rotation": [float(x) for x in Rotation.from_matrix(skel.rotation[i]).as_quat()]}
        kids = [c for c in range(len(skel)) if skel.parents[c] == i]
        if kids:
            node["children"] = kids
        nodes.append(node)
    roots = [i for i in range(len(skel)) if skel.parents[i] < 0]
    gltf = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": roots}], "nodes": nodes,
            "skins": [{"joints": list(range(len(skel)))}]}
    if humanoid is not None:
        idx = {n: i for i, n in enumerate(names)}
        if vrm == "1":
            gltf["extensionsUsed"] = ["VRMC_vrm"]
            gltf["extensions"] = {"VRMC_vrm": {"specVersion": "1.0", "humanoid": {
                "humanBones": {b: {"node": idx[n]} for b, n in humanoid.items()}}}}
        else:
            gltf["extensionsUsed"] = ["VRM"]
            gltf["extensions"] = {"VRM": {"humanoid": {
                "humanBones": [{"bone": b, "node": idx[n]} for b, n in humanoid.items()]}}}
    js = json.dumps(gltf).encode()
    js += b" " * (-len(js) % 4)
    with open(path, "wb") as fh:
        fh.write(struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(js)))
        fh.write(struct.pack("<I4s", len(js), b"JSON") + js)
    return gltf


PLAYER = Path(__file__).resolve().parents[1] / "gesturelsm" / "webapp" / "player"


def bundle_character_js(folder: Path) -> Path | None:
    """gesturelsm/webapp/player/src/character.js bundled (esbuild, iife) so a page gets `window.C`; None when the
    player's npm packages are not installed."""
    import json
    import subprocess

    esbuild = PLAYER / "node_modules" / ".bin" / "esbuild"
    if not esbuild.exists() or not (PLAYER / "node_modules" / "@pixiv" / "three-vrm").is_dir():
        return None
    entry = folder / "entry.js"
    entry.write_text(f"import * as C from {json.dumps(str(PLAYER / 'src' / 'character.js'))};\nwindow.C = C;\n")
    out = folder / "character_bundle.js"
    subprocess.run([str(esbuild), str(entry), "--bundle", "--format=iife", f"--outfile={out}"],
                   check=True, capture_output=True, timeout=120, cwd=PLAYER)
    return out


def gltf_validator_errors(path: Path, folder: Path) -> tuple[int, list] | None:
    """(number of errors, their messages) from the Khronos glTF validator (npm gltf-validator run by node), or
    None when node or the package is not installed."""
    import json
    import shutil
    import subprocess

    node, package = shutil.which("node"), PLAYER / "node_modules" / "gltf-validator"
    if node is None or not package.is_dir():
        return None
    script = folder / "validate.cjs"
    script.write_text(
        "const v = require(process.argv[2]); const fs = require('fs');\n"
        "v.validateBytes(new Uint8Array(fs.readFileSync(process.argv[3])), {maxIssues: 100}).then(r => "
        "console.log(JSON.stringify({errors: r.issues.numErrors, messages: r.issues.messages"
        ".filter(m => m.severity === 0)})));\n")
    run = subprocess.run([node, str(script), str(package), str(path)], capture_output=True, text=True, timeout=120)
    report = json.loads(run.stdout)
    return report["errors"], report["messages"]


@contextlib.contextmanager
def character_js_page(folder: Path) -> Iterator:
    """A blank headless Chromium page holding `bundle_character_js` as `window.C`; skips, saying why, when chromium
    or the player's npm packages are missing."""
    import pytest
    from playwright.sync_api import sync_playwright

    from _support import CHROMIUM

    if CHROMIUM is None:
        pytest.skip("chromium is not installed (scripts/setup.sh installs it)")
    bundle = bundle_character_js(folder)
    if bundle is None:
        pytest.skip("the player's npm packages are not installed (cd gesturelsm/webapp/player && npm ci)")
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        try:
            page = browser.new_page()
            page.set_content("<html><body></body></html>")
            page.add_script_tag(content=bundle.read_text())
            yield page
        finally:
            browser.close()


def bvh_positions(path: Path) -> tuple[list[str], np.ndarray]:
    """Joint names and (T, N, 3) world positions of a ZXY BVH, by its own forward kinematics."""
    text = path.read_text()
    names, parents, offsets, _ = parse_hierarchy(text, path.name)
    rows = text.split("Frame Time:", 1)[1].split("\n", 1)[1].split()
    data = np.asarray(rows, np.float64).reshape(-1, 3 + 3 * len(names))
    R = euler_zxy_to_matrix(np.radians(data[:, 3:].reshape(len(data), -1, 3)))
    G, P = np.empty_like(R), np.empty((len(data), len(names), 3))
    for i, p in enumerate(parents):
        if p < 0:
            G[:, i], P[:, i] = R[:, i], data[:, :3]
        else:
            G[:, i] = G[:, p] @ R[:, i]
            P[:, i] = P[:, p] + G[:, p] @ offsets[i]
    return names, P
