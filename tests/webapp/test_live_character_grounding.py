"""The Live tab on a character with other legs than SMPL-X's (gesturelsm/webapp/live_character.py with
gesturelsm/retarget/grounding.py `CharacterStreamGrounder`): streamed chunk by chunk, its feet are grounded causally on
its own legs, as the same causal grounder gives the whole stream at once; planted within 1 cm; its upper body the
retargeted one bit for bit; off when the stream's grounding is."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from _rigs import build_rig, vrm_body_bones, write_gltf
from _standing import other_legs, segments, standing, stepping, swaying
from gesturelsm.grounding import ground_motion
from gesturelsm.retarget import SourceBody, load_character, retarget
from gesturelsm.retarget.grounding import CharacterStreamGrounder
from gesturelsm.retarget.solve import prepare

pytest.importorskip("gradio")
from gesturelsm.export.character_payload import bone_order
from gesturelsm.live.characters import CharacterStream

CHUNKS = (20, 20, 7, 33, 20, 1, 19)


@pytest.fixture(scope="module")
def character(body, tmp_path_factory):
    skel, _ = build_rig(other_legs(body.rest_joints()), fingers=False)
    path = tmp_path_factory.mktemp("legs") / "legs.vrm"
    write_gltf(skel, path, humanoid=vrm_body_bones())
    return load_character(path)


@pytest.fixture(scope="module")
def motion():
    """What live mode streams: the SMPL-X motion grounded (here offline, on the mannequin), feet planted."""
    res = ground_motion(stepping(swaying(standing(seconds=8.0, seed=3)), "left", every=2.5, length=0.7, offset=1.0))
    return res.motion, res.contacts


def stream(character, seq, body, grounding=True):
    s, out, a, k = CharacterStream(character, body, grounding=grounding), [], 0, 0
    while a < seq.num_frames:
        n = CHUNKS[k % len(CHUNKS)]
        out.append(s.chunk(seq.slice(a, a + n)))
        a, k = a + n, k + 1
    return s, np.concatenate([q for q, _, _ in out]), np.concatenate([r for _, r, _ in out])


def test_streamed_character_is_grounded_causally_on_its_own_legs(character, motion, body):
    seq, contacts = motion
    s, q, root = stream(character, seq, body)
    setup = prepare(character.skeleton, SourceBody.of(body))
    whole = CharacterStreamGrounder(setup).push(retarget(seq, character.skeleton, setup.source, s.ground, setup))
    assert whole.note is None
    order = bone_order(character.skeleton)
    T, B = q.shape[:2]
    got = Rotation.from_quat(q.reshape(-1, 4)).as_matrix().reshape(T, B, 3, 3)
    np.testing.assert_allclose(got, whole.local_rotation[:, order], atol=1e-5)        # float32 quaternions
    np.testing.assert_allclose(root, whole.root_translation, atol=1e-5)
    b = character.skeleton.bones
    for f, side in enumerate(("left", "right")):                       # the whole's feet: planted within 1 cm
        for a, e in segments(contacts[:, f]):
            if e - a > 25:
                P = whole.positions[a + 10:e - 10, b[f"{side}_ankle"]]
                assert np.linalg.norm(P - P[0], axis=1).max() <= 0.01
    _, q_off, root_off = stream(character, seq, body, grounding=False)
    legs = [order.index(b[n]) for n in ("left_hip", "left_knee", "left_ankle", "right_hip", "right_knee",
                                         "right_ankle")]
    others = [k for k in range(B) if k not in legs]
    assert np.array_equal(q[:, others], q_off[:, others])               # the upper body: as retargeted
    assert not np.allclose(q[:, legs], q_off[:, legs], atol=1e-3) and not np.allclose(root, root_off, atol=1e-3)
