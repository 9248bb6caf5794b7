"""Linear blend skinning of a character's own mesh (gesturelsm/retarget/skinning.py, mesh.py), on skinned box
characters the tests build: the rest pose gives the bind pose, one rotated joint turns exactly its vertices
(and its children's) about itself, weights blend linearly, morph targets add their deltas, and the joint
matrices put every joint where an independent forward kinematics of the retargeted motion does."""
from __future__ import annotations

import copy

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from _rigs import build_rig, posed_world, vrm_body_bones
from _skinned import box_mesh, write_skinned_glb
from gesturelsm.body.model import resolve_body
from gesturelsm.motion import MotionSequence
from gesturelsm.motion.skeleton import JOINT_INDEX
from gesturelsm.retarget import CharacterError, load_character, retarget_motion
from gesturelsm.retarget.mesh import character_mesh
from gesturelsm.retarget.skinning import joint_world, local_matrices, pose_mesh, pose_part, rest_world, world_from_local


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """A VRM 1.0 of boxes (Z-up centimetre rig world turned by its own node axes), its Character and CharacterMesh."""
    skel, _ = build_rig(resolve_body(None).rest_joints(), fingers=False, axes=True, seed=3)
    path = tmp_path_factory.mktemp("skin") / "boxes.vrm"
    tex = np.zeros((4, 4, 4), np.uint8)
    tex[..., 1], tex[..., 3] = 200, 255
    write_skinned_glb(skel, path, vrm_body_bones(), presets=("aa", "oh"), texture=tex)
    character = load_character(path)
    return skel, character, character_mesh(character.document, character.skeleton)


def test_the_file_is_read_back_as_written(built):
    skel, character, mesh = built
    pos, faces, joint = box_mesh(skel)
    (part,) = mesh.parts
    np.testing.assert_allclose(part.positions, pos, atol=1e-6)
    np.testing.assert_array_equal(part.faces, faces)
    names = [character.skeleton.names[part.skin_joints[j]] for j in part.joints[:, 0]]
    assert names == [skel.names[j] for j in joint]
    assert part.texture.shape == (4, 4, 4) and part.texture[0, 0].tolist() == [0, 200, 0, 255]
    assert part.targets.shape == (2, len(pos), 3) and part.double_sided


def test_rest_pose_gives_the_bind_pose(built):
    _, character, mesh = built
    (v,), _ = pose_mesh(mesh, rest_world(character.skeleton))
    np.testing.assert_allclose(v, mesh.parts[0].positions, atol=1e-5)


def test_one_rotated_joint_turns_its_vertices_about_itself(built):
    _, character, mesh = built
    skel = character.skeleton
    part = mesh.parts[0]
    elbow = skel.bones["left_elbow"]
    R = Rotation.from_rotvec([0.3, -0.8, 0.5]).as_matrix()
    rot = skel.rotation.copy()
    rot[elbow] = rot[elbow] @ R
    world = world_from_local(skel, local_matrices(skel, rot[None]))[0]
    (v,), _ = pose_mesh(mesh, world)
    rest = skel.world()
    p = rest[elbow, :3, 3]
    G = rest[elbow, :3, :3] @ R @ np.linalg.inv(rest[elbow, :3, :3])          # the turn, in world axes
    owner = part.skin_joints[part.joints[:, 0]]
    below = np.array([o == elbow or _is_below(skel.parents, o, elbow) for o in owner])
    assert below.sum() >= 16 and (~below).sum() > 100
    np.testing.assert_allclose(v[below], (part.positions[below] - p) @ G.T + p, atol=1e-5)
    np.testing.assert_allclose(v[~below], part.positions[~below], atol=1e-5)


def _is_below(parents, child: int, ancestor: int) -> bool:
    while child >= 0:
        child = int(parents[child])
        if child == ancestor:
            return True
    return False


def test_weights_blend_linearly(built):
    _, character, mesh = built
    skel = character.skeleton
    part = copy.deepcopy(mesh.parts[0])
    rng = np.random.default_rng(0)
    rot = skel.rotation[None] @ Rotation.random(len(skel), random_state=1).as_matrix()[None]
    world = world_from_local(skel, local_matrices(skel, rot))[0]
    a, b = skel.bones["left_wrist"], skel.bones["right_knee"]
    inv = {int(j): k for k, j in enumerate(part.skin_joints)}
    part.joints = np.tile([inv[a], inv[b], 0, 0], (len(part.positions), 1))
    w = rng.uniform(0, 1, len(part.positions))
    only = []
    for weights in ([1.0, 0, 0, 0], [0, 1.0, 0, 0]):
        part.weights = np.tile(weights, (len(w), 1))
        only.append(pose_part(part, world)[0])
    part.weights = np.stack([w, 1 - w, 0 * w, 0 * w], 1)
    np.testing.assert_allclose(pose_part(part, world)[0], w[:, None] * only[0] + (1 - w[:, None]) * only[1],
                               atol=1e-9)


def test_morph_targets_add_their_deltas_before_skinning(built):
    _, character, mesh = built
    part = mesh.parts[0]
    (v,), _ = pose_mesh(mesh, rest_world(character.skeleton), {0: np.array([0.5, 1.0])})
    np.testing.assert_allclose(v, part.positions + 0.5 * part.targets[0] + part.targets[1], atol=1e-5)
    head = part.skin_joints[part.joints[:, 0]] == character.skeleton.bones["head"]
    assert np.abs(v - part.positions)[head].max() > 0.005 and np.abs(v - part.positions)[~head].max() < 1e-5


def test_joint_matrices_follow_the_retargeted_motion(built):
    _, character, _ = built
    T = 12
    poses = np.zeros((T, 165))
    poses[:, 3 * JOINT_INDEX["left_shoulder"] + 2] = np.linspace(-1.0, 1.2, T)
    poses[:, 3 * JOINT_INDEX["spine2"]] = np.linspace(0, 0.4, T)
    seq = MotionSequence(poses, np.tile([0.1, 1.0, 0.2], (T, 1)) + np.linspace(0, 0.3, T)[:, None],
                         np.zeros((T, 100)))
    result = retarget_motion(seq, character)
    W = joint_world(result, np.arange(T))
    np.testing.assert_allclose(W[..., :3, 3], posed_world(result), atol=1e-9)
    np.testing.assert_allclose(W[..., :3, 3], result.positions, atol=1e-6)


def test_a_mesh_without_skin_weights_is_refused(built, tmp_path):
    _, character, _ = built
    doc = copy.deepcopy(character.document)
    del doc.gltf["meshes"][0]["primitives"][0]["attributes"]["WEIGHTS_0"]
    with pytest.raises(CharacterError, match="JOINTS_0 / WEIGHTS_0"):
        character_mesh(doc, character.skeleton)
    doc.gltf["meshes"] = []
    doc.gltf["nodes"] = [n for n in doc.gltf["nodes"] if "mesh" not in n]
    with pytest.raises(CharacterError, match="no triangle mesh"):
        character_mesh(doc, character.skeleton)


def test_accessors_with_stride_sparse_values_and_normalised_integers():
    from gesturelsm.retarget.gltf import GltfDocument
    from gesturelsm.retarget.mesh import accessor

    base = np.arange(12, dtype=np.float32).reshape(4, 3)
    strided = np.zeros((4, 4), np.float32)
    strided[:, :3] = base                                                    # 16-byte stride, 12 bytes used
    idx, vals = np.array([1, 3], np.uint16), np.array([[9, 9, 9], [7, 7, 7]], np.float32)
    norm = np.array([[0, 255], [51, 255]], np.uint8)
    blob = strided.tobytes() + idx.tobytes() + vals.tobytes() + norm.tobytes()
    views = [{"buffer": 0, "byteOffset": 0, "byteLength": 64, "byteStride": 16},
             {"buffer": 0, "byteOffset": 64, "byteLength": 4}, {"buffer": 0, "byteOffset": 68, "byteLength": 24},
             {"buffer": 0, "byteOffset": 92, "byteLength": 4}]
    accessors = [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
                 {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "sparse": {
                     "count": 2, "indices": {"bufferView": 1, "componentType": 5123},
                     "values": {"bufferView": 2}}},
                 {"componentType": 5126, "count": 4, "type": "VEC3", "sparse": {
                     "count": 2, "indices": {"bufferView": 1, "componentType": 5123}, "values": {"bufferView": 2}}},
                 {"bufferView": 3, "componentType": 5121, "count": 2, "type": "VEC2", "normalized": True}]
    doc = GltfDocument({"asset": {"version": "2.0"}, "bufferViews": views, "accessors": accessors}, blob, "t.glb")
    np.testing.assert_array_equal(accessor(doc, 0), base)
    np.testing.assert_array_equal(accessor(doc, 1), [[0, 1, 2], [9, 9, 9], [6, 7, 8], [7, 7, 7]])
    np.testing.assert_array_equal(accessor(doc, 2), [[0, 0, 0], [9, 9, 9], [0, 0, 0], [7, 7, 7]])
    np.testing.assert_allclose(accessor(doc, 3), [[0, 1], [0.2, 1]])
    short = GltfDocument(doc.gltf, blob[:59], "t.glb")                      # the last vertex needs 60 bytes
    with pytest.raises(CharacterError, match="truncated"):
        accessor(short, 0)


def test_an_unskinned_mesh_follows_its_parent_bone_rigidly(built):
    _, character, _ = built
    doc = copy.deepcopy(character.document)
    skel = character.skeleton
    head = skel.bones["head"]
    g = doc.gltf
    g["nodes"].append({"name": "hat", "mesh": 0, "translation": [0.0, 0.2, 0.0]})   # no skin: an accessory
    g["nodes"][skel.nodes[head]].setdefault("children", []).append(len(g["nodes"]) - 1)
    mesh = character_mesh(doc, skel)
    hat = next(p for p in mesh.parts if p.joints is None)
    assert hat.rigid_joint == head
    rest = skel.world()
    rot = skel.rotation.copy()
    rot[skel.bones["neck"]] = rot[skel.bones["neck"]] @ Rotation.from_rotvec([0.4, 0.2, -0.3]).as_matrix()
    world = world_from_local(skel, local_matrices(skel, rot[None]))[0]
    v_rest, _ = pose_part(hat, rest)
    lift = np.eye(4)
    lift[1, 3] = 0.2
    np.testing.assert_allclose(v_rest, hat.positions @ (rest[head] @ lift)[:3, :3].T + (rest[head] @ lift)[:3, 3],
                               atol=1e-9)
    moved = world[head] @ np.linalg.inv(rest[head])                           # the head's own motion
    np.testing.assert_allclose(pose_part(hat, world)[0], v_rest @ moved[:3, :3].T + moved[:3, 3], atol=1e-9)


def test_primitives_sharing_vertices_are_skinned_once_and_drawn_with_their_own_material(built):
    _, character, _ = built
    doc = copy.deepcopy(character.document)
    prims = doc.gltf["meshes"][0]["primitives"]
    prims.append({**prims[0], "material": len(doc.gltf["materials"])})      # same attributes, another material
    doc.gltf["materials"].append({"pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 1.0, 1.0]}})
    mesh = character_mesh(doc, character.skeleton)
    a, b = mesh.parts
    assert b.shares == 0 and b.positions is a.positions and mesh.num_vertices == len(a.positions)
    assert b.color == (0.0, 0.0, 1.0, 1.0) and b.texture is None and a.texture is not None
    verts, _ = pose_mesh(mesh, rest_world(character.skeleton))
    assert verts[1] is verts[0]
