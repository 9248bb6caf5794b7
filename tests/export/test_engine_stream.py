"""`gesturelsm stream` and the senders behind it: pacing on a loopback receiver, Live Link Face packets read by an
independent struct reader in Unreal's order, bad addresses in one line, an absent receiver never stalling, and
the face's procedural blinks."""
from __future__ import annotations

import socket
import struct

import numpy as np
import pytest

from _osc import Receiver, decode_bundle
from gesturelsm.cli import main
from gesturelsm.errors import UserError
from gesturelsm.export.alive import Blinker
from gesturelsm.export.arkit import ARKIT_NAMES, arkit_face
from gesturelsm.export.engine_stream import EngineStream, parse_address
from gesturelsm.export.live_link import read_live_link_csv, write_live_link_csv
from gesturelsm.motion import MotionSequence

# Unreal's EARKitBlendShape order (ARTrackable.h), written out independently of the module
UNREAL = """EyeBlinkLeft EyeLookDownLeft EyeLookInLeft EyeLookOutLeft EyeLookUpLeft EyeSquintLeft EyeWideLeft
EyeBlinkRight EyeLookDownRight EyeLookInRight EyeLookOutRight EyeLookUpRight EyeSquintRight EyeWideRight JawForward
JawLeft JawRight JawOpen MouthClose MouthFunnel MouthPucker MouthLeft MouthRight MouthSmileLeft MouthSmileRight
MouthFrownLeft MouthFrownRight MouthDimpleLeft MouthDimpleRight MouthStretchLeft MouthStretchRight MouthRollLower
MouthRollUpper MouthShrugLower MouthShrugUpper MouthPressLeft MouthPressRight MouthLowerDownLeft MouthLowerDownRight
MouthUpperUpLeft MouthUpperUpRight BrowDownLeft BrowDownRight BrowInnerUp BrowOuterUpLeft BrowOuterUpRight CheekPuff
CheekSquintLeft CheekSquintRight NoseSneerLeft NoseSneerRight TongueOut HeadYaw HeadPitch HeadRoll LeftEyeYaw
LeftEyePitch LeftEyeRoll RightEyeYaw RightEyePitch RightEyeRoll""".split()


def read_live_link(data: bytes) -> dict:
    """A Live Link Face packet, read with struct alone (big-endian)."""
    i = 0
    (version,) = struct.unpack_from(">B", data, i)
    i += 1
    strings = []
    for _ in range(2):
        (n,) = struct.unpack_from(">i", data, i)
        strings.append(data[i + 4:i + 4 + n].decode("utf-8"))
        i += 4 + n
    frame, sub, num, den, count = struct.unpack_from(">ifiiB", data, i)
    i += 17
    values = struct.unpack_from(f">{count}f", data, i)
    assert i + 4 * count == len(data)
    return {"version": version, "device": strings[0], "subject": strings[1], "frame": frame, "sub": sub,
            "fps": (num, den), "count": count, "values": dict(zip(UNREAL, values))}


def speaking_motion(seconds: float, fps: int = 30) -> MotionSequence:
    """A motion whose jaw opens and closes like syllables (4 a second) and whose arms sway."""
    T = int(seconds * fps)
    t = np.arange(T) / fps
    poses = np.zeros((T, 165))
    poses[:, 66] = 0.06 * np.clip(np.sin(2 * np.pi * 4 * t), 0, None) * (np.sin(2 * np.pi * 0.2 * t) > -0.5)
    poses[:, 3 * 16 + 2] = -0.8 + 0.3 * np.sin(2 * np.pi * 0.5 * t)
    poses[:, 3 * 17 + 2] = 0.8 + 0.3 * np.cos(2 * np.pi * 0.5 * t)
    return MotionSequence(poses, np.tile([0.0, 0.9, 0.0], (T, 1)), np.zeros((T, 100)))


@pytest.mark.slow
def test_stream_a_10_s_take_paced_in_real_time(tmp_path, capsys):
    path = speaking_motion(10.0).save(tmp_path / "take.npz")
    rx, ll = Receiver(), Receiver()
    try:
        assert main(["stream", str(path), "--vmc", rx.address, "--livelink", ll.address]) == 0
        rx.wait_for(300, timeout=5)
    finally:
        rx.close()
        ll.close()
    n = len(rx.packets)
    span = rx.packets[-1][0] - rx.packets[0][0]
    assert 270 <= n <= 330 and 8.5 <= span <= 12.5, (n, span)
    for _, data in rx.packets:
        bones = [m[1][0] for m in decode_bundle(data) if m[0] == "/VMC/Ext/Bone/Pos"]
        assert len(bones) == 55
    assert 270 <= len(ll.packets) <= 330
    assert "sent" in capsys.readouterr().out


def test_live_link_packets_in_unreals_order_follow_the_csv(tmp_path):
    seq = speaking_motion(2.0)
    rx = Receiver()
    try:
        EngineStream(livelink=parse_address(rx.address, "--livelink"), say=lambda s: None).play(seq)
        rx.wait_for(seq.num_frames, timeout=5)
    finally:
        rx.close()
    packets = [read_live_link(d) for _, d in rx.packets]
    assert len(packets) == seq.num_frames
    assert all(p["version"] == 6 and p["count"] == 61 and p["fps"] == (30, 1) for p in packets)
    assert [p["frame"] for p in packets] == list(range(seq.num_frames))
    csv = read_live_link_csv(write_live_link_csv(arkit_face(seq), tmp_path / "face.csv"))
    jaw = np.array([p["values"]["JawOpen"] for p in packets])
    assert np.allclose(jaw, csv.weight("JawOpen"), atol=1e-5) and jaw.max() > 0.25
    for name in ("JawLeft", "MouthLeft", "MouthRight", "EyeBlinkLeft", "BrowInnerUp"):
        assert np.allclose([p["values"][name] for p in packets], csv.weight(name), atol=1e-5)
    assert np.allclose([p["values"]["HeadPitch"] for p in packets], csv.head[:, 1], atol=1e-5)
    assert UNREAL.index("JawLeft") < UNREAL.index("JawRight") and ARKIT_NAMES.index("JawRight") < \
        ARKIT_NAMES.index("JawLeft")


@pytest.mark.parametrize("text", ["localhost", "127.0.0.1:", ":39539", "127.0.0.1:0", "127.0.0.1:70000",
                                  "127.0.0.1:port", "no.such.host.invalid:39539"])
def test_a_bad_address_is_one_line_and_status_2(text, tmp_path, capsys):
    path = speaking_motion(0.5).save(tmp_path / "take.npz")
    assert main(["stream", str(path), "--vmc", text]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--vmc" in err and "Traceback" not in err
    with pytest.raises(UserError):
        parse_address(text)


def test_an_absent_receiver_never_stalls():
    """Nobody listens on the port: every frame still leaves on its clock (none dropped, none waited on)."""
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    seq = speaking_motion(1.0)
    stream = EngineStream(vmc=parse_address(f"127.0.0.1:{port}"), livelink=parse_address(f"127.0.0.1:{port}"),
                          say=lambda s: None)
    report = stream.play(seq)
    stream.close()
    assert report.frames == seq.num_frames and report.sent + report.dropped == seq.num_frames
    assert report.seconds < 5.0


def test_a_stall_drops_frames_instead_of_a_burst():
    """A clock that jumps 1 s ahead once: those frames are dropped and said, the rest keep their times."""
    seq = speaking_motion(2.0)
    said: list[str] = []
    stream = EngineStream(vmc=parse_address("127.0.0.1:9"), say=said.append)
    now = {"t": 0.0, "calls": 0}

    def clock() -> float:
        now["calls"] += 1
        if now["calls"] == 10:
            now["t"] += 1.0
        return now["t"]

    import gesturelsm.export.engine_stream as es
    sleep = es.time.sleep
    es.time.sleep = lambda s: now.__setitem__("t", now["t"] + s)
    try:
        report = stream.play(seq, clock=clock)
    finally:
        es.time.sleep = sleep
        stream.close()
    assert 25 <= report.dropped <= 31 and report.sent == seq.num_frames - report.dropped
    assert len(said) == 1 and "dropped" in said[0]


def test_blinks_are_natural_irregular_and_not_always_mid_word():
    fps, minutes = 30, 5
    T = fps * 60 * minutes
    t = np.arange(T) / fps
    mouth = 0.4 * (np.sin(2 * np.pi * 4 * t) > 0) * (np.sin(2 * np.pi * 0.15 * t) > -0.6)   # words, pauses
    w = Blinker(fps, seed=3).next(mouth)
    starts = np.nonzero((w[1:] >= 0.5) & (w[:-1] < 0.5))[0] + 1
    rate = len(starts) / minutes
    assert 6 <= rate <= 30, rate
    gaps = np.diff(starts) / fps
    assert gaps.std() / gaps.mean() > 0.25 and gaps.min() >= 1.0
    assert 0.0 < (mouth[starts] > 0.15).mean() < 1.0          # some blinks mid-word, not all
    assert w.max() == pytest.approx(1.0) and w.min() == 0.0
    chunked = Blinker(fps, seed=3)
    assert np.allclose(np.concatenate([chunked.next(mouth[i:i + 37]) for i in range(0, T, 37)]), w)


def test_speech_plays_in_sync_where_there_is_an_audio_output_and_one_line_where_none(tmp_path, capsys, monkeypatch):
    """No audio output (this machine): one line, and the motion streams. A (stand-in) player: started with the
    speech decoded to a wav as the first frame leaves, and stopped at the end."""
    import sys

    import soundfile as sf
    from _support import speech_like
    from gesturelsm.commands import stream as stream_cli

    path = speaking_motion(0.5).save(tmp_path / "take.npz")
    wav = tmp_path / "speech.wav"
    sf.write(wav, speech_like(0.5), 16000)
    monkeypatch.setattr(stream_cli, "audio_output", lambda: None)
    assert main(["stream", str(path), "--vmc", "127.0.0.1:9", "--speech", str(wav)]) == 0
    out = capsys.readouterr().out
    assert out.count("no audio output") == 1 and "of 15 frames" in out
    log = tmp_path / "played.txt"
    script = "import os, sys; open(sys.argv[1], 'w').write(str(os.path.getsize(sys.argv[2])))"
    monkeypatch.setattr(stream_cli, "audio_output", lambda: (sys.executable, ["-c", script, str(log)]))
    assert main(["stream", str(path), "--vmc", "127.0.0.1:9", "--speech", str(wav)]) == 0
    assert "no audio output" not in capsys.readouterr().out
    assert int(log.read_text()) == 44 + 2 * 8000             # the speech as a 16 kHz 16-bit wav (the player ran)
