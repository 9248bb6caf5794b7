"""Feet on the ground on a character's own legs (gesturelsm/retarget/grounding.py): a character with longer shins,
shorter thighs and wider hips than SMPL-X slides its feet under a motion whose SMPL-X feet are planted; grounded
on its own skeleton they stay within 1 cm while planted, its upper body's rotations are the retargeted ones bit for
bit, and the files written for it (VRM / GLB animation, BVH) carry the grounded legs, read back. Legs that cannot be
grounded pass through with a one-line note."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from _rigs import Y_UP_TO_Z_UP, build_rig, bvh_positions, vrm_body_bones, write_gltf
from _standing import other_legs, segments, standing, stepping, swaying
from gesturelsm.cli import main
from gesturelsm.export.glb import accessor_array, read_glb
from gesturelsm.export.rig import export_rig_bvh, export_rig_glb
from gesturelsm.grounding import ground_motion
from gesturelsm.retarget import load_character, retarget_motion
from gesturelsm.retarget.grounding import leg_problem

LEGS = ("left_hip", "left_knee", "left_ankle", "left_foot", "right_hip", "right_knee", "right_ankle", "right_foot")
UNITS = {"vrm": 1.0, "glb": 100.0}


@pytest.fixture(scope="module")
def grounded():
    """The SMPL-X motion as the pipeline gives it: standing, shifting its weight, the right foot stepping in place,
    grounded on the mannequin (its feet planted): (motion, its contacts)."""
    res = ground_motion(stepping(swaying(standing(seconds=10.0, seed=2)), "right", every=2.5, length=0.7, offset=1.0))
    assert res.note is None
    return res.motion, res.contacts


@pytest.fixture(scope="module", params=["vrm", "glb"])
def character(request, body, tmp_path_factory):
    """Other legs than SMPL-X's: a VRM 1.0 in metres (no toe bones), and a Mixamo-named GLB, Z-up in centimetres with
    its own bone axes (toes)."""
    J = other_legs(body.rest_joints())
    folder = tmp_path_factory.mktemp("legs")
    if request.param == "vrm":
        skel, _ = build_rig(J, fingers=False)
        write_gltf(skel, folder / "legs.vrm", humanoid=vrm_body_bones())
        return load_character(folder / "legs.vrm")
    skel, _ = build_rig(J, axes=True, world=Y_UP_TO_Z_UP, units=UNITS["glb"], seed=3)
    write_gltf(skel, folder / "legs.glb")
    return load_character(folder / "legs.glb")


def units(character) -> float:
    return UNITS[character.path.suffix[1:]]


def leg_bones(character) -> list[int]:
    return [character.skeleton.bones[n] for n in LEGS if n in character.skeleton.bones]


def feet_of(positions: np.ndarray, character) -> dict[str, np.ndarray]:
    """{SMPL-X name: (T, 3) world positions} of the character's ankles and toes."""
    b = character.skeleton.bones
    return {n: positions[:, b[n]] for n in ("left_ankle", "left_foot", "right_ankle", "right_foot") if n in b}


def planted_motion(feet: dict[str, np.ndarray], contacts: np.ndarray, character) -> float:
    """The most a foot joint (ankle, toes) moves within a contact of the SMPL-X feet (10 frames in from each end), m."""
    worst = 0.0
    for name, X in feet.items():
        for a, e in segments(contacts[:, 0 if name.startswith("left") else 1]):
            if e - a > 25:
                P = X[a + 10:e - 10] / units(character)
                worst = max(worst, float(np.linalg.norm(P - P[0], axis=1).max()))
    return worst


def test_the_characters_feet_stay_planted_on_its_own_legs(grounded, character, body):
    seq, contacts = grounded
    off = retarget_motion(seq, character, body, grounding=False)
    on = retarget_motion(seq, character, body)
    assert on.note is None and off.note is None
    slid, held = planted_motion(feet_of(off.positions, character), contacts, character), \
        planted_motion(feet_of(on.positions, character), contacts, character)
    assert slid > 0.015 and held <= 0.01, (slid, held)    # other legs: the retargeted feet slide; grounded: planted
    up = np.argmax(np.abs(on.align[1]))                                     # the character's world up axis
    sign = np.sign(on.align[1, up])
    feet = [character.skeleton.bones[n] for n in ("left_ankle", "right_ankle")]
    rest_low = (character.skeleton.world()[feet, up, 3] * sign).min()
    assert (on.positions[:, feet, up] * sign).min() >= rest_low - 0.002 * units(character)   # nothing sinks


def test_only_the_legs_change_the_upper_body_bit_for_bit(grounded, character, body):
    seq, _ = grounded
    off = retarget_motion(seq, character, body, grounding=False)
    on = retarget_motion(seq, character, body)
    legs = leg_bones(character)
    others = [i for i in sorted(character.skeleton.bones.values()) if i not in legs]
    assert np.array_equal(on.local_rotation[:, others], off.local_rotation[:, others])
    assert not np.allclose(on.local_rotation[:, legs[:3]], off.local_rotation[:, legs[:3]], atol=1e-3)
    knee, ankle = character.skeleton.bones["left_knee"], character.skeleton.bones["left_ankle"]
    shin = np.linalg.norm(on.positions[:, ankle] - on.positions[:, knee], axis=1)
    np.testing.assert_allclose(shin, shin[0], rtol=1e-6)                    # bones keep their lengths


def test_the_files_carry_the_grounded_legs(grounded, character, body, tmp_path):
    seq, contacts = grounded
    on = retarget_motion(seq, character, body)
    skel = character.skeleton
    by_node = {skel.nodes[i]: i for i in range(len(skel))}
    gltf, blob = read_glb(export_rig_glb(seq, character, tmp_path / f"take{character.path.suffix}", body))
    anim = gltf["animations"][0]
    seen = set()
    for ch in anim["channels"]:
        data = accessor_array(gltf, blob, anim["samplers"][ch["sampler"]]["output"])
        i = by_node[ch["target"]["node"]]
        if ch["target"]["path"] == "translation":
            np.testing.assert_allclose(data, on.root_translation, atol=1e-4 * units(character))
        elif i in leg_bones(character):
            np.testing.assert_allclose(Rotation.from_quat(data).as_matrix(), on.local_rotation[:, i], atol=1e-5)
            seen.add(i)
    assert seen == set(leg_bones(character))
    names, P = bvh_positions(export_rig_bvh(seq, character, tmp_path / "take.bvh", body))
    for n in ("left_ankle", "right_ankle", "head", "right_wrist"):
        i = skel.bones[n]
        np.testing.assert_allclose(P[:, names.index(skel.names[i].replace(" ", "_"))], on.positions[:, i],
                                   atol=1e-4 * units(character))
    feet = {n: P[:, names.index(skel.names[skel.bones[n]].replace(" ", "_"))] for n in ("left_ankle", "right_ankle")}
    assert planted_motion(feet, contacts, character) <= 0.01                # the BVH's feet are planted


def test_export_rig_grounds_unless_told_not_to(grounded, character, body, tmp_path):
    seq, _ = grounded
    seq.save(tmp_path / "take.npz")
    for mode, want in (("on", retarget_motion(seq, character, body)),
                       ("off", retarget_motion(seq, character, body, grounding=False))):
        out = tmp_path / f"{mode}{character.path.suffix}"
        args = ["export", str(tmp_path / "take.npz"), "--rig", str(character.path), "--glb", str(out)]
        assert main(args + (["--grounding", "off"] if mode == "off" else [])) == 0
        gltf, blob = read_glb(out)
        anim = gltf["animations"][0]
        root = next(ch for ch in anim["channels"] if ch["target"]["path"] == "translation")
        got = accessor_array(gltf, blob, anim["samplers"][root["sampler"]]["output"])
        np.testing.assert_allclose(got, want.root_translation, atol=1e-4 * units(character))


def degenerate(character, how: str):
    """The character's skeleton with a leg made unusable: a shin of no length, or one leg shorter (its rest pose does
    not stand on both feet)."""
    skel = character.skeleton
    t = skel.translation.copy()
    ankle = skel.bones["left_ankle"]
    t[ankle] *= 0.0 if how == "no shin" else 0.6
    return replace(character, skeleton=replace(skel, translation=t))


@pytest.mark.parametrize("how, says", [("no shin", "has no length"), ("short leg", "both feet")])
def test_legs_that_cannot_be_grounded_pass_through_with_one_line(grounded, character, body, how, says, tmp_path,
                                                                 capsys):
    seq, _ = grounded
    bad = degenerate(character, how)
    on = retarget_motion(seq, bad, body)
    off = retarget_motion(seq, bad, body, grounding=False)
    assert says in on.note and "cannot be grounded" in on.note and "\n" not in on.note
    np.testing.assert_array_equal(on.local_rotation, off.local_rotation)
    np.testing.assert_array_equal(on.root_translation, off.root_translation)
    assert leg_problem(bad.skeleton) == on.note and leg_problem(character.skeleton) is None


def test_a_motion_that_cannot_be_grounded_on_the_character_passes_through(grounded, character, body):
    seq, _ = grounded
    one = retarget_motion(seq.slice(0, 1), character, body)
    assert "1 frame" in one.note
    np.testing.assert_array_equal(one.local_rotation,
                                  retarget_motion(seq.slice(0, 1), character, body, grounding=False).local_rotation)
