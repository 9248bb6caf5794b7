"""`gesturelsm live FILE`: writes the streamed motion (offline frame count) and prints latency; bad input is one
line."""
from __future__ import annotations

import re

import numpy as np
import soundfile as sf

from gesturelsm.cli import main
from gesturelsm.motion.sequence import MotionSequence

from _support import speech_like


def test_live_cli_writes_motion_and_reports_latency(shipped_pipe, tmp_path, capsys):
    wav = tmp_path / "speech.wav"
    sf.write(wav, speech_like(2.5, seed=8), 16000)
    assert main(["live", str(wav), "--chunk-ms", "150", "--steps", "1", "--out", str(tmp_path / "m.npz")]) == 0
    out = capsys.readouterr().out
    assert "latency median" in out and "real-time factor" in out
    m = MotionSequence.load(tmp_path / "m.npz")
    assert m.num_frames == 75 and np.isfinite(m.poses).all()


def test_live_cli_bad_input_is_one_clear_line(tmp_path, capsys):
    assert main(["live", str(tmp_path / "missing.wav")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not found" in err[0]
    wav = tmp_path / "s.wav"
    sf.write(wav, speech_like(1.0), 16000)
    assert main(["live", str(wav), "--chunk-ms", "0"]) == 2
    assert "--chunk-ms" in capsys.readouterr().err


def test_live_cli_grounds_causally_by_default_and_off_keeps_the_decoders_legs(shipped_pipe, tmp_path, capsys):
    """The same stream with --grounding on (the default) and off: the upper body and face are bit for bit the same,
    only the legs and root differ, and the grounded stream is the ungrounded one grounded by the causal core in one
    go (the generator's chunks do not matter: equal to float32)."""
    from gesturelsm.grounding.motion_stream import MotionStreamGrounder

    from _standing import KEPT_COLUMNS

    wav = tmp_path / "speech.wav"
    sf.write(wav, speech_like(3.0, seed=9), 16000)
    for mode in ("on", "off"):
        args = ["live", str(wav), "--steps", "1", "--out", str(tmp_path / f"{mode}.npz")]
        assert main(args + (["--grounding", "off"] if mode == "off" else [])) == 0
        assert f"feet on the ground: {mode}" in capsys.readouterr().out
    on, off = (MotionSequence.load(tmp_path / f"{m}.npz") for m in ("on", "off"))
    assert np.array_equal(on.poses[:, KEPT_COLUMNS], off.poses[:, KEPT_COLUMNS])
    assert np.array_equal(on.expressions, off.expressions)
    assert not np.allclose(on.poses[:, 3:9], off.poses[:, 3:9])
    whole = MotionStreamGrounder().push(off)
    assert whole.note is None
    np.testing.assert_allclose(on.poses, whole.motion.poses, atol=1e-5)
    np.testing.assert_allclose(on.trans, whole.motion.trans, atol=1e-5)


def test_live_cli_sends_the_stream_to_a_vmc_and_live_link_receiver(shipped_pipe, tmp_path, capsys):
    """`live --vmc --livelink`: a loopback receiver gets one VMC bundle (55 HumanBodyBones) and one Live Link Face
    packet per streamed frame while the speech is generated; a bad address is one line before any work."""
    from _osc import Receiver, decode_bundle

    wav = tmp_path / "speech.wav"
    sf.write(wav, speech_like(2.0, seed=4), 16000)
    rx, ll = Receiver(), Receiver()
    try:
        assert main(["live", str(wav), "--steps", "1", "--vmc", rx.address, "--livelink", ll.address]) == 0
        rx.wait_for(60, timeout=10)
        ll.wait_for(60, timeout=10)
    finally:
        rx.close()
        ll.close()
    out = capsys.readouterr().out
    m = re.search(r"sent (\d+) frames to .*; dropped (\d+) late", out)
    sent, dropped = int(m.group(1)), int(m.group(2))
    assert sent + dropped == 60 and sent >= 30, out                    # 2 s at 30 fps (a loaded machine drops some)
    assert len(rx.packets) == sent and len(ll.packets) == sent
    msgs = decode_bundle(rx.packets[30][1])
    assert sum(m[0] == "/VMC/Ext/Bone/Pos" for m in msgs) == 55 and msgs[-1][0] == "/VMC/Ext/T"
    assert ll.packets[0][1][0] == 6                                    # Live Link Face's version byte
    assert main(["live", str(wav), "--vmc", "127.0.0.1"]) == 2
    assert "--vmc" in capsys.readouterr().err
