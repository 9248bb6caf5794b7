"""Motion files from anyone: every crafted file of tests/_hostile_motions.py is refused by the one
reader (motion/motion_file.py) in one line, and through every command that reads a motion (export in every
format, export --rig, render, edit): exit status 2, one line, no traceback, no file written, and the files whose
data would take gigabytes stay far below 1.5 GB. BEAT2's own files and the unusual valid ones load as they are.
docs/HOSTILE.md lists each file with what it gets."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from _hostile_motions import ACCEPTED, BOMBS, HOSTILE, make
from _support import speech_like
from gesturelsm.errors import MotionFileError
from gesturelsm.motion import MotionSequence
from gesturelsm.motion.motion_file import read_motion_file

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def crafted(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("hostile_motions")
    return {name: make(name, folder) for name in HOSTILE}


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, Path]:
    """A speech file and a character for the commands (never reached: the motion is refused first)."""
    from _rigs import build_rig, write_gltf
    from gesturelsm.body import resolve_body

    folder = tmp_path_factory.mktemp("hostile_inputs")
    sf.write(folder / "speech.wav", speech_like(1.5), 16000)
    skel, _ = build_rig(resolve_body(None).rest_joints(), fingers=False)
    write_gltf(skel, folder / "me.glb")
    return {"speech": folder / "speech.wav", "rig": folder / "me.glb"}


def commands(motion: Path, out: Path, inputs: dict) -> dict[str, list[str]]:
    m = str(motion)
    return {
        "export (npz, bvh, glb, keypoints, arkit)": ["export", m, "--npz", str(out / "a.npz"), "--bvh",
                                                     str(out / "a.bvh"), "--glb", str(out / "a.glb"), "--keypoints",
                                                     str(out / "kp"), "--arkit", str(out / "a.csv")],
        "export --rig": ["export", m, "--rig", str(inputs["rig"]), "--glb", str(out / "r.glb"), "--bvh",
                         str(out / "r.bvh")],
        "render": ["render", m, "--audio", str(inputs["speech"]), "--out", str(out / "v.mp4"), "--quiet"],
        "edit": ["edit", m, str(inputs["speech"]), "--regenerate", "upper@0.2-1.0", "--no-transcribe", "--out",
                 str(out / "e.npz"), "--bvh", str(out / "e.bvh")],
    }


@pytest.mark.parametrize("name", list(HOSTILE))
def test_the_reader_refuses_each_crafted_file_in_one_line(crafted, name):
    with pytest.raises(MotionFileError) as err:
        MotionSequence.load(crafted[name])
    message = str(err.value)
    assert HOSTILE[name][1] in message and "\n" not in message and message.startswith(str(crafted[name]))


@pytest.mark.parametrize("name", list(ACCEPTED))
def test_unusual_valid_files_load(tmp_path, name):
    seq = MotionSequence.load(make(name, tmp_path))
    assert seq.num_frames == ACCEPTED[name][1] and seq.fps == 30
    assert seq.poses.dtype == np.float32 and seq.expressions.shape == (seq.num_frames, 100)
    assert seq.betas.shape == (300,)


def test_beat2s_own_take_loads_as_it_is(beat2_root):
    path = beat2_root / "smplxflame_30" / "2_scott_0_1_1.npz"
    seq = MotionSequence.load(path)
    with np.load(path) as d:                      # float64 trans and expressions, string model / gender, int rate
        assert d["model"].dtype.kind == "U" and d["trans"].dtype == np.float64
        assert np.array_equal(seq.poses, d["poses"]) and np.allclose(seq.trans, d["trans"], atol=1e-6)
        assert np.allclose(seq.expressions, d["expressions"], atol=1e-6) and seq.num_frames == len(d["poses"])


def test_a_rate_other_than_30_is_resampled_in_time(tmp_path):
    """60 fps: every other frame (rotations exactly, translation too); 24 fps: a frame between two is between."""
    from _hostile_motions import motion, write_npz

    m = motion(frames=61, mocap_frame_rate=np.array(60.0))
    m["trans"] = np.stack([np.linspace(0, 6, 61), np.full(61, 0.9), np.zeros(61)], 1).astype(np.float32)
    seq = MotionSequence.load(write_npz(tmp_path / "m60.npz", m))
    assert seq.num_frames == 31 and np.allclose(seq.poses, m["poses"][::2], atol=1e-5)
    assert np.allclose(seq.trans[:, 0], np.arange(31) * 0.2, atol=1e-5)          # 6 m in 1 s of motion at 60 fps
    data = read_motion_file(write_npz(tmp_path / "m24.npz", motion(frames=25, mocap_frame_rate=np.array(24))))
    assert data.source_fps == 24 and len(data.poses) == 31


def test_the_transcript_and_word_times_are_kept_through_save_and_load(tmp_path):
    seq = MotionSequence.load(make("transcript and word timings", tmp_path, ACCEPTED))
    assert seq.transcript == "hello there" and [w for w, _, _ in seq.words] == ["hello", "there"]
    back = MotionSequence.load(seq.save(tmp_path / "again.npz"))
    assert back.transcript == "hello there" and np.allclose([a for _, a, _ in back.words], [0.1, 0.5])
    with np.load(tmp_path / "again.npz", allow_pickle=False) as d:       # plain arrays: no pickle needed
        assert d["words"].dtype.kind == "U" and d["word_times"].dtype == np.float32 and d["transcript"].shape == ()


def test_every_command_refuses_every_crafted_file(crafted, inputs, tmp_path, capsys):
    """export (every format), export --rig, render and edit: exit 2, one line, no traceback, nothing written."""
    from gesturelsm.cli import main

    wrong = []
    for name, path in crafted.items():
        for what, argv in commands(path, tmp_path / "out", inputs).items():
            (tmp_path / "out").mkdir(exist_ok=True)
            code = main(argv)
            out, err = capsys.readouterr()
            lines = err.strip().splitlines()
            written = sorted(p.name for p in (tmp_path / "out").iterdir())
            if code != 2 or len(lines) != 1 or "Traceback" in err or written or HOSTILE[name][1] not in err:
                wrong.append((name, what, code, err[-300:], written))
    assert wrong == []


_MEASURE = """
import contextlib, io, json, sys
from gesturelsm.cli import main
codes = []
for argv in json.loads(sys.argv[1]):
    with contextlib.redirect_stderr(io.StringIO()) as err, contextlib.redirect_stdout(io.StringIO()):
        codes.append((main(argv), err.getvalue().strip()))
# VmHWM: this process's own peak; getrusage's ru_maxrss keeps the forking parent's peak across exec
peak = next(int(x.split()[1]) for x in open("/proc/self/status") if x.startswith("VmHWM:"))
print(json.dumps({"codes": codes, "peak": peak * 1024}))
"""


@pytest.mark.parametrize("name", BOMBS)
def test_files_whose_data_would_take_gigabytes_stay_below_1_5_gb(crafted, inputs, tmp_path, name):
    """Each command on the file in a fresh process: its peak resident memory (VmHWM), imports included."""
    runs = list(commands(crafted[name], tmp_path, inputs).values())
    done = subprocess.run([sys.executable, "-c", _MEASURE, json.dumps(runs)], capture_output=True, text=True,
                          cwd=REPO, check=True)
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert all(code == 2 and HOSTILE[name][1] in err for code, err in result["codes"]), result["codes"]
    assert result["peak"] < 1.5e9, f"peak {result['peak'] / 1e9:.2f} GB"
    assert list(tmp_path.iterdir()) == []
