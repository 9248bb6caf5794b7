"""`gesturelsm stream MOTION.npz --vmc HOST:PORT`: play a motion in real time to VTuber apps, Unity, Unreal and
Blender over the VMC protocol and / or Unreal's Live Link Face (docs/ENGINES.md).

    gesturelsm stream take.npz --vmc 127.0.0.1:39539                         # VSeeFace, VNyan, Warudo, EVMC4U ...
    gesturelsm stream take.npz --vmc 127.0.0.1:39539 --perfect-sync --loop   # + the 52 ARKit blendshapes
    gesturelsm stream take.npz --livelink 127.0.0.1:11111 --speech take.wav  # Unreal's Live Link Face source
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from ..constants import SAMPLE_RATE
from ..errors import UserError

NAME = "stream"
HELP = "play a motion in real time to VTuber apps / Unity / Unreal (VMC, Live Link)"
PLAYER_GRACE_S = 2.0
PLAYERS = (("paplay", []), ("aplay", ["-q"]), ("afplay", []),
           ("ffplay", ["-nodisp", "-autoexit", "-loglevel", "quiet"]))


def audio_output() -> tuple[str, list[str]] | None:
    """A command that plays a wav on this machine's audio output, or None when it has none (no sound card and no
    sound server, or no player program)."""
    cards = Path("/proc/asound/cards")
    linux = sys.platform.startswith("linux")
    has_card = cards.exists() and "no soundcards" not in cards.read_text(errors="replace").lower() \
        and cards.read_text(errors="replace").strip() != ""
    runtime = os.environ.get("XDG_RUNTIME_DIR", "")
    has_server = bool(os.environ.get("PULSE_SERVER")) or (runtime and Path(runtime, "pulse", "native").exists())
    for name, args in PLAYERS:
        exe = shutil.which(name)
        if exe is None:
            continue
        if name == "paplay" and not has_server:
            continue
        if name in ("aplay", "ffplay") and linux and not (has_card or has_server):
            continue
        return exe, args
    return None


def _stop_player(p: subprocess.Popen, grace: float) -> None:
    """Let the speech end (up to `grace` s past the motion's last frame), then stop its player."""
    try:
        p.wait(timeout=grace)
    except subprocess.TimeoutExpired:
        p.terminate()
        p.wait()


def add_parser(sub) -> None:
    p = sub.add_parser(NAME, help=HELP,
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("motion", help="BEAT2-layout .npz motion file")
    p.add_argument("--vmc", help="send VMC protocol bundles to HOST:PORT (receivers listen on 39539)")
    p.add_argument("--livelink", help="send Live Link Face packets to HOST:PORT (Unreal listens on 11111)")
    p.add_argument("--speech", help="play this speech file in sync, where the machine has an audio output")
    p.add_argument("--loop", action="store_true",
                   help="play again and again until interrupted (Ctrl-C; the speech plays once)")
    p.add_argument("--perfect-sync", action="store_true",
                   help="VMC: the 52 ARKit blendshapes too (perfect-sync avatars), besides the VRM presets")
    p.add_argument("--model", help="SMPL-X npz (default: $GESTURELSM_SMPLX_MODEL or the built-in mannequin)")
    p.set_defaults(func=run)


def _speech_player(path: str, say) -> tuple[list[str], str] | None:
    """The player's command line for `path` (decoded to a temporary wav), or None (said in one line)."""
    out = audio_output()
    if out is None:
        say("no audio output on this machine (no sound card or sound server): streaming the motion without speech")
        return None
    import numpy as np
    import soundfile

    from ..audio import load_audio

    audio = load_audio(path)
    fd, wav = tempfile.mkstemp(suffix=".wav", prefix="gesturelsm_speech_")
    os.close(fd)
    soundfile.write(wav, np.asarray(audio, np.float32), SAMPLE_RATE)
    return [out[0], *out[1], wav], wav


def run(args: argparse.Namespace) -> int:
    from ..export.engine_stream import EngineStream, parse_address
    from ..motion.sequence import MotionSequence

    vmc = parse_address(args.vmc, "--vmc") if args.vmc else None
    livelink = parse_address(args.livelink, "--livelink") if args.livelink else None
    if vmc is None and livelink is None:
        raise UserError("nothing to stream to: give --vmc HOST:PORT and / or --livelink HOST:PORT")
    if args.speech and not Path(args.speech).is_file():
        raise UserError(f"--speech {args.speech}: file not found")
    if not Path(args.motion).is_file():
        raise UserError(f"motion file not found: {args.motion}")
    seq = MotionSequence.load(args.motion)
    if seq.num_frames == 0:
        raise UserError(f"{args.motion}: the motion has no frames")
    stream = EngineStream(vmc, livelink, args.perfect_sync, args.model, seq.fps)
    player = _speech_player(args.speech, print) if args.speech else None
    proc: list[subprocess.Popen] = []

    def started() -> None:
        if player is not None:
            proc.append(subprocess.Popen(player[0], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))

    to = ", ".join(f"{k} {a}" for k, a in (("VMC", vmc), ("Live Link Face", livelink)) if a is not None)
    print(f"streaming {seq.num_frames} frames ({seq.num_frames / seq.fps:.1f} s at {seq.fps} fps) to {to}"
          + ("; looping, Ctrl-C stops" if args.loop else ""))
    interrupted = False
    try:
        report = stream.play(seq, loop=args.loop, started=started)
    except KeyboardInterrupt:
        report, interrupted = stream.report, True
        print("stopped")
    finally:
        stream.close()
        for p in proc:
            _stop_player(p, 0.0 if interrupted else PLAYER_GRACE_S)
        if player is not None:
            Path(player[1]).unlink(missing_ok=True)
    print(f"sent {report.sent} of {report.frames} frames in {report.seconds:.1f} s; dropped {report.dropped} late "
          f"(in {len(report.stalls)} stalls); {report.failed} datagrams not taken by the system")
    return 0
