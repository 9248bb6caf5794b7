"""The Live tab on the visitor's character, server side (gesturelsm/webapp/live_character.py, live.py `payload`,
live_socket.py): chunk by chunk retargeting gives what retargeting the whole motion gives (rotations, quaternion
signs, root motion), with no jump at chunk borders; without a character the live records are the mannequin's,
byte for byte; the page sessions' tokens resolve to their characters and expire; over the socket a hello with a
token streams version-2 records whose character section is the retargeted motion."""
from __future__ import annotations

import json
import shutil
import struct
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from _rigs import Y_UP_TO_Z_UP, build_rig, write_gltf
from _support import speech_like, synthetic_motion, until
from gesturelsm.export.glb import continuous_quaternions, matrix_to_quaternion_xyzw
from gesturelsm.export.motion_codec import CHARACTER_VERSION, HEADER, VERSION, decode, encode
from gesturelsm.export.player_payload import motion_record
from gesturelsm.motion.sequence import MotionSequence
from gesturelsm.retarget import load_character, retarget_motion

pytest.importorskip("gradio")
from gesturelsm.export.character_payload import bone_order, character_payload
from gesturelsm.webapp.live import payload
from gesturelsm.live.characters import EXPIRED, CharacterStream, LiveCharacters
from gesturelsm.webapp.player.component import file_url

CHUNKS = (20, 20, 7, 33, 20, 20)          # the live feed's 20-frame chunks, and uneven ones


@pytest.fixture(scope="module")
def character(body, tmp_path_factory):
    """A Z-up rig in centimetres with its own bone axes, written as a .glb and read back as the page reads it."""
    skel, _ = build_rig(body.rest_joints(), axes=True, world=Y_UP_TO_Z_UP, units=100.0, lengths=0.2)
    path = tmp_path_factory.mktemp("rig") / "me.glb"
    write_gltf(skel, path)
    return load_character(path)


@pytest.fixture(scope="module")
def motion() -> MotionSequence:
    """Smooth gestures whose root walks, sways and bobs (so a per-chunk root reference would show)."""
    seq = synthetic_motion(frames=sum(CHUNKS), seed=4)
    t = np.arange(seq.num_frames)[:, None] / 30
    seq.trans = (np.array([[0.4, 0.0, 0.3]]) * t + np.array([[0.0, 0.05, 0.0]]) * np.sin(3 * t)).astype(np.float32)
    return seq


def streamed(character, motion, body) -> tuple[CharacterStream, np.ndarray, np.ndarray]:
    """The stream on the character as retargeted (its feet grounded on its legs: test_live_character_grounding.py)."""
    stream = CharacterStream(character, body, grounding=False)
    out, a = [], 0
    for n in CHUNKS:
        out.append(stream.chunk(motion.slice(a, a + n)))
        a += n
    return stream, np.concatenate([q for q, _, _ in out]), np.concatenate([r for _, r, _ in out])


def test_streamed_chunks_equal_retargeting_the_whole_motion(character, motion, body):
    stream, q, root = streamed(character, motion, body)
    whole = retarget_motion(motion, character, body, grounding=False)
    order = bone_order(character.skeleton)
    T, B = q.shape[:2]
    assert (T, B) == (motion.num_frames, len(character.skeleton.bones))
    got = Rotation.from_quat(q.reshape(-1, 4)).as_matrix().reshape(T, B, 3, 3)
    np.testing.assert_allclose(got, whole.local_rotation[:, order], atol=1e-5)
    # the same signs as the whole motion's sign-continuous quaternions (what the offline page plays)
    np.testing.assert_allclose(q, continuous_quaternions(matrix_to_quaternion_xyzw(whole.local_rotation[:, order])),
                               atol=1e-5)
    # the root: the whole motion's, on the stream's reference (its first frame, its first chunk's floor) ...
    np.testing.assert_allclose(root, retarget_motion(motion, character, body, ground=stream.ground,
                                                     grounding=False).root_translation, atol=1e-3)   # centimetres
    # ... which differs from the whole motion's own by one constant offset (its floor is the whole take's lowest foot)
    offset = root - whole.root_translation
    assert np.ptp(offset, axis=0).max() < 1e-3
    np.testing.assert_allclose(stream.ground.pelvis, whole.ground.pelvis, atol=1e-9)


def test_no_jump_at_chunk_borders(character, motion, body):
    _, q, root = streamed(character, motion, body)
    borders = np.cumsum(CHUNKS)[:-1]
    dots = (q[1:] * q[:-1]).sum(-1)                                     # (T-1, B)
    assert dots.min() > 0.9                                             # no sign flip anywhere, borders included
    step = np.linalg.norm(np.diff(root, axis=0), axis=1)                # (T-1,) root step per frame (cm)
    inside = np.delete(step, borders - 1)
    assert step[borders - 1].max() <= 1.5 * inside.max()
    # retargeting each chunk on its own (its own start and floor) would jump: this motion shows it
    naive = np.concatenate([retarget_motion(motion.slice(a - n, a), character, body, grounding=False).root_translation
                            for a, n in zip(np.cumsum(CHUNKS), CHUNKS)])
    assert np.linalg.norm(np.diff(naive, axis=0), axis=1)[borders - 1].max() > 3 * inside.max()


def wait_idle(mgr) -> None:
    until(lambda: mgr.active == 0, "every live stream ended")


class FakeSession:
    """What live.py `payload` reads of a LiveSession: poll(), stats(), delivered."""

    def __init__(self, seq: MotionSequence, start: int):
        self.chunks = [SimpleNamespace(start=start, motion=seq)]
        self.delivered = start

    def poll(self):
        out, self.chunks = self.chunks, []
        return out

    def stats(self) -> dict:
        return {"frames": 99, "audio_seconds": 3.3, "median_latency_ms": 612.0, "p90_latency_ms": 700.0,
                "real_time_factor": 2.5}


def test_without_a_character_the_records_are_the_mannequins_byte_for_byte(character, motion, body):
    seq = motion.slice(20, 40)
    data = payload(FakeSession(seq, 20), "streaming", body)[0]
    meta = {"frames": 99, "audio_seconds": 3.3, "median_latency_ms": 612.0, "p90_latency_ms": 700.0,
            "real_time_factor": 2.5, "status": "streaming"}
    assert data == encode(motion_record(seq, body, 20, meta))
    assert HEADER.unpack_from(data)[1] == VERSION == 1
    with_char = payload(FakeSession(seq, 20), "streaming", body, CharacterStream(character, body))[0]
    rec, plain = decode(with_char), decode(data)
    assert HEADER.unpack_from(with_char)[1] == CHARACTER_VERSION
    for k in ("rotations", "root", "expressions"):                     # the mannequin's arrays are all still there
        np.testing.assert_array_equal(getattr(rec, k), getattr(plain, k))
    q, r, w = CharacterStream(character, body).chunk(seq)
    np.testing.assert_array_equal(rec.bone_rotations, q)
    np.testing.assert_array_equal(rec.bone_root, r)
    # a rig without face presets: no morph channels, and its records are the bone-only layout (F = 0 at byte 30)
    assert w.shape == (20, 0) and rec.morph is None and struct.unpack_from("<H", with_char, 30)[0] == 0
    assert CharacterStream(character, body).spec()["morphs"] == []
    page = character_payload(character, {"m": seq}, body)
    assert "morphs" not in page and set(page["methods"]["m"]) == {"quats", "root"}


def test_streamed_face_weights_equal_the_whole_motions(body, motion, tmp_path):
    """A VRM with visemes and blink: each chunk's morph weights are the whole motion's at those frames, the export's
    `morph_weights(alive_face_weights(...))` (blinks included), in the channel order the stream's spec lists; the
    records carry them."""
    from _skinned import face_vrm
    from gesturelsm.export.alive import alive_face_weights
    from gesturelsm.retarget.face import PRESETS, morph_weights

    vrm = load_character(face_vrm(tmp_path / "face.vrm", vrm="1"))
    gltf = vrm.document.gltf
    stream = CharacterStream(vrm, body)
    channels = [tuple(c) for c in stream.spec()["morphs"]]
    assert channels == [(0, k) for k in range(len(PRESETS))]            # one head-box target per preset
    got, a = [], 0
    for n in CHUNKS:
        data = payload(FakeSession(motion.slice(a, a + n), a), "streaming", body, stream)[0]
        rec = decode(data)
        assert struct.unpack_from("<H", data, 30)[0] == len(channels) and rec.morph.shape == (n, len(channels))
        got.append(rec.morph)
        a += n
    got = np.concatenate(got)
    per_mesh = morph_weights(gltf, alive_face_weights(body, motion))
    np.testing.assert_allclose(got, np.stack([per_mesh[m][:, k] for m, k in channels], axis=1), atol=1e-6)
    assert got.max() > 0.1 and np.ptp(got, axis=0).max() > 0.1             # the mouth moves in this motion


def test_tokens_resolve_to_the_chosen_character_and_expire(character, tmp_path):
    chars = LiveCharacters(tmp_path, file_url, max_entries=2)
    token, spec = chars.choose(character, None)
    assert isinstance(token, str) and len(token) >= 32 and spec["token"] == token and spec["name"] == "me.glb"
    rest = CharacterStream(character).spec()                             # the live player shows it at rest with these
    assert {k: spec[k] for k in rest} == rest
    served = Path(spec["url"].split("file=", 1)[1])
    assert served.parent.parent == tmp_path and served.parent.name.startswith("req-")     # swept like requests
    assert served.read_bytes() == character.path.read_bytes()
    assert chars.get(token).character is character
    assert chars.get("not-a-token") is None and chars.get(None) is None and chars.get(["x"]) is None
    shutil.rmtree(served.parent)                                        # the sweeper took the copy
    assert Path(chars.get(token).serve().split("file=", 1)[1]).read_bytes() == character.path.read_bytes()
    again, _ = chars.choose(character, token)                            # chose again: the old token is gone
    assert chars.get(token) is None and chars.get(again) is not None and not served.parent.exists()
    assert chars.choose(None, again) == (None, None) and chars.get(again) is None and len(chars) == 0
    tokens = [chars.register(character) for _ in range(3)]               # at most max_entries, the oldest go
    assert chars.get(tokens[0]) is None and all(chars.get(t) for t in tokens[1:])
    short = LiveCharacters(tmp_path, file_url, ttl_s=0.05)
    t = short.register(character)
    time.sleep(0.1)
    assert short.get(t) is None


def test_over_the_socket_the_stream_is_on_the_tokens_character(shipped_pipe, character, body, tmp_path):
    from starlette.applications import Starlette
    from starlette.testclient import TestClient

    from gesturelsm.live import LiveConfig
    from gesturelsm.live.session import LiveManager
    from gesturelsm.webapp import live_socket

    chars = LiveCharacters(tmp_path, file_url)
    token = chars.register(character)
    mgr = LiveManager(shipped_pipe, max_sessions=1, config=LiveConfig(steps=1))
    client = TestClient(Starlette(routes=live_socket.routes(mgr, body, chars)))

    def run(hello: dict) -> list:
        with client.websocket_connect(live_socket.PATH) as ws:
            ws.send_text(json.dumps(hello))
            y = (np.clip(speech_like(2.0, seed=7), -1, 1) * 32767).astype("<i2")
            for a in range(0, len(y), 1600):
                ws.send_bytes(y[a:a + 1600].tobytes())
            ws.send_text(json.dumps({"end": True}))
            out = []
            while not out or out[-1].meta["status"] == "streaming":
                out.append(decode(ws.receive_bytes()))
        return out

    first, *msgs = run({"sample_rate": 16000, "character": token, "grounding": False})   # as retargeted
    spec = first.meta["character"]
    assert first.frames == 0 and first.meta["status"] == "streaming"
    assert spec["name"] == "me.glb" and spec["nodes"] == [character.skeleton.nodes[i]
                                                           for i in bone_order(character.skeleton)]
    assert spec["url"].startswith("gradio_api/file=") and spec["key"] == chars.get(token).key
    framed = [m for m in msgs if m.frames]
    assert sum(m.frames for m in framed) == 60 and all(m.bone_rotations is not None for m in framed)
    # the streamed SMPL-X motion, back from the mannequin's quaternions (the mannequin adds no pose mean)
    rot = np.concatenate([m.rotations for m in framed])
    poses = Rotation.from_quat(rot.reshape(-1, 4)).as_rotvec().reshape(len(rot), -1)
    trans = np.concatenate([m.root for m in framed]) - body.rest_joints()[0]
    seq = MotionSequence(poses.astype(np.float32), trans.astype(np.float32), np.zeros((len(rot), 100), np.float32))
    ground = retarget_motion(seq.slice(0, framed[0].frames), character, body, grounding=False).ground
    want = retarget_motion(seq, character, body, ground=ground, grounding=False)
    q = np.concatenate([m.bone_rotations for m in framed])
    got = Rotation.from_quat(q.reshape(-1, 4)).as_matrix().reshape(len(q), -1, 3, 3)
    np.testing.assert_allclose(got, want.local_rotation[:, bone_order(character.skeleton)], atol=1e-4)
    np.testing.assert_allclose(np.concatenate([m.bone_root for m in framed]), want.root_translation, atol=0.05)
    wait_idle(mgr)
    # a token the server does not hold: said once, then the mannequin's records (version 1)
    first, *msgs = run({"sample_rate": 16000, "character": "forged"})
    assert first.meta == {"status": "streaming", "character_error": EXPIRED}
    assert all(m.bone_rotations is None for m in msgs) and sum(m.frames for m in msgs) == 60
    wait_idle(mgr)


def test_the_hello_names_a_token_or_nothing():
    from gesturelsm.webapp.live_socket import MessageRefused, hello

    assert hello('{"sample_rate": 48000}') == (48000, None)
    assert hello('{"sample_rate": 16000, "character": "abc"}') == (16000, "abc")
    with pytest.raises(MessageRefused, match="the token the page was given"):
        hello('{"sample_rate": 16000, "character": {"path": "/etc/passwd"}}')


def test_a_character_the_retargeting_refuses_is_a_message_and_the_mannequin(character, body, tmp_path):
    """A rig a million times too large: the socket's first message says why, and no character stream is made."""
    from dataclasses import replace

    from gesturelsm.webapp.live_socket import stream_character

    chars = LiveCharacters(tmp_path, file_url)
    huge = replace(character, skeleton=replace(character.skeleton, translation=character.skeleton.translation * 1e6))
    stream, meta = stream_character(chars, chars.register(huge), body)
    assert stream is None and "absurd scale" in meta["character_error"] and meta["status"] == "streaming"
    stream, meta = stream_character(chars, chars.register(character), body)
    assert isinstance(stream, CharacterStream) and meta["character"]["name"] == "me.glb"
