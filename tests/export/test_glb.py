"""GLB: trimesh opens it; the JSON/binary are consistent glTF 2.0; evaluating the skin and animation
from the file alone reproduces the body model's joints and vertices."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from gesturelsm.export import export_glb, read_glb
from gesturelsm.export.glb import accessor_array, top_k_weights


def test_trimesh_loads_mesh_and_animation_is_present(tmp_path, wild_motion, body):
    path = export_glb(wild_motion, tmp_path / "m.glb", body=body)
    scene = trimesh.load(path)
    geoms = list(scene.geometry.values())
    assert len(geoms) == 1 and len(geoms[0].vertices) == body.num_vertices and len(geoms[0].faces) == len(body.faces)
    gltf, blob = read_glb(path)
    assert gltf["asset"]["version"] == "2.0" and len(gltf["animations"]) == 1
    anim = gltf["animations"][0]
    paths = [(c["target"]["node"], c["target"]["path"]) for c in anim["channels"]]
    assert sum(p == "rotation" for _, p in paths) == 55 and (0, "translation") in paths
    times = accessor_array(gltf, blob, anim["samplers"][0]["input"])[:, 0]
    assert len(times) == wild_motion.num_frames and np.allclose(np.diff(times), 1 / 30, atol=1e-6) and times[0] == 0
    assert all(s["interpolation"] == "LINEAR" for s in anim["samplers"])
    skin = gltf["skins"][0]
    assert skin["joints"] == list(range(55)) and gltf["nodes"][0]["name"] == "Hips"


def test_gltf_structure_is_consistent(tmp_path, wild_motion, body):
    gltf, blob = read_glb(export_glb(wild_motion, tmp_path / "m.glb", body=body))
    assert gltf["buffers"][0]["byteLength"] <= len(blob)
    size = {5126: 4, 5121: 1, 5123: 2, 5125: 4}
    ncomp = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}
    for acc in gltf["accessors"]:
        view = gltf["bufferViews"][acc["bufferView"]]
        assert view["byteOffset"] % 4 == 0
        assert acc["count"] * ncomp[acc["type"]] * size[acc["componentType"]] <= view["byteLength"]
        assert view["byteOffset"] + view["byteLength"] <= len(blob)
    prim = gltf["meshes"][0]["primitives"][0]
    pos = gltf["accessors"][prim["attributes"]["POSITION"]]
    assert "min" in pos and "max" in pos
    w = accessor_array(gltf, blob, prim["attributes"]["WEIGHTS_0"])
    j = accessor_array(gltf, blob, prim["attributes"]["JOINTS_0"])
    assert np.allclose(w.sum(1), 1, atol=1e-6) and (w >= 0).all() and j.max() < 55
    assert ((w == 0) | (j < 55)).all()
    for s in gltf["animations"][0]["samplers"]:
        assert "min" in gltf["accessors"][s["input"]] and "max" in gltf["accessors"][s["input"]]
    q = accessor_array(gltf, blob, gltf["animations"][0]["samplers"][3]["output"])
    assert np.allclose(np.linalg.norm(q, axis=1), 1, atol=1e-6)
    assert (np.einsum("ij,ij->i", q[1:], q[:-1]) >= 0).all(), "quaternion signs are continuous"
    nodes = gltf["nodes"]
    mesh_node = next(n for n in nodes if "mesh" in n)
    assert "skin" in mesh_node and "translation" not in mesh_node and "rotation" not in mesh_node


def evaluate(gltf, blob, frame):
    """Joint world matrices at `frame` from the file: rest node transforms + sampled animation."""
    nodes = gltf["nodes"]
    local_t = {i: np.array(n.get("translation", [0, 0, 0]), float) for i, n in enumerate(nodes)}
    local_r = {i: np.eye(3) for i in range(len(nodes))}
    weights = None
    for ch in gltf["animations"][0]["channels"]:
        out = accessor_array(gltf, blob, gltf["animations"][0]["samplers"][ch["sampler"]]["output"])
        node, path = ch["target"]["node"], ch["target"]["path"]
        if path == "rotation":
            local_r[node] = Rotation.from_quat(out[frame]).as_matrix()        # x, y, z, w
        elif path == "translation":
            local_t[node] = out[frame].astype(float)
        elif path == "weights":
            k = len(gltf["meshes"][nodes[node]["mesh"]]["weights"])
            weights = out.reshape(-1, k)[frame]
    world = {}

    def visit(i, parent):
        M = np.eye(4)
        M[:3, :3], M[:3, 3] = local_r[i], local_t[i]
        world[i] = parent @ M
        for c in nodes[i].get("children", []):
            visit(c, world[i])

    for r in gltf["scenes"][0]["nodes"]:
        visit(r, np.eye(4))
    return world, weights


@pytest.mark.parametrize("which", ["mannequin", "hand_mean"])
def test_animation_and_skin_reproduce_the_body(tmp_path, wild_motion, body, hand_mean_body, which):
    body = body if which == "mannequin" else hand_mean_body
    gltf, blob = read_glb(export_glb(wild_motion, tmp_path / "m.glb", body=body))
    prim = gltf["meshes"][0]["primitives"][0]
    rest = accessor_array(gltf, blob, prim["attributes"]["POSITION"]).astype(float)
    jidx = accessor_array(gltf, blob, prim["attributes"]["JOINTS_0"]).astype(int)
    jw = accessor_array(gltf, blob, prim["attributes"]["WEIGHTS_0"]).astype(float)
    ibm = accessor_array(gltf, blob, gltf["skins"][0]["inverseBindMatrices"]).reshape(-1, 4, 4).transpose(0, 2, 1)
    targets = [accessor_array(gltf, blob, t["POSITION"]) for t in prim.get("targets", [])]
    assert len(targets) == 3, "the mannequin's 3 expression directions become morph targets"
    ref = body.forward(wild_motion.poses, wild_motion.trans, wild_motion.expressions, wild_motion.betas)
    for frame in (0, 5, 11):
        world, wts = evaluate(gltf, blob, frame)
        J = np.stack([world[j][:3, 3] for j in range(55)])
        assert np.abs(J - ref.joints[frame]).max() < 1e-5
        v = rest + sum(w * t for w, t in zip(wts, targets))
        skin = np.stack([world[j] @ ibm[j] for j in range(55)])              # (55, 4, 4)
        M = (skin[jidx] * jw[..., None, None]).sum(1)                          # (V, 4, 4)
        posed = (M[:, :3, :3] @ v[:, :, None])[..., 0] + M[:, :3, 3]
        assert np.abs(posed - ref.vertices[frame]).max() < 2e-4, "LBS from the file = the body model"


def test_top_k_weights_renormalise():
    W = np.array([[0.5, 0.2, 0.1, 0.1, 0.1], [1.0, 0, 0, 0, 0]])
    idx, w = top_k_weights(W, 4)
    assert np.allclose(w.sum(1), 1) and idx[0, 0] == 0 and np.isclose(w[0, 0], 0.5 / 0.9)
    assert np.allclose(w[1], [1, 0, 0, 0])
