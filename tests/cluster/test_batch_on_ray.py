"""`gesturelsm batch --cluster` on a simulated two-node Ray cluster: the same study folder as a run in this process
(the motion behind every video byte for byte, the key), and a node taken away mid-batch still gives every video
exactly once. The workers get the test checkpoints by value (no shared disk is assumed)."""
from __future__ import annotations

import csv
import re
import shutil
import threading
import time
from pathlib import Path

import pytest
import soundfile as sf

from _support import speech_like

METHODS = ["gesturelsm", "ddim"]


@pytest.fixture(scope="module")
def speech_dir(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("speech")
    sf.write(d / "alpha.wav", speech_like(1.0, seed=1), 16000)
    sf.write(d / "beta.flac", speech_like(1.2, sr=22050, seed=2), 22050)
    (d / "beta.txt").write_text("hello there")
    return d


def _batch(speech_dir: Path, out: Path, assets: Path, *extra: str) -> tuple[int, str]:
    import contextlib
    import io

    from gesturelsm.cli import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(err):
        code = main(["batch", "--audio-dir", str(speech_dir), "--methods", *METHODS, "--out", str(out), "--raters",
                     "2", "--steps", "1", "--ddim-steps", "2", "--size", "128", "--checkpoints", str(assets), *extra])
    return code, err.getvalue()


def _motions(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "key" / "motion").glob("*.npz"))}


@pytest.fixture(scope="module")
def local_study(tiny_assets, speech_dir, tmp_path_factory) -> Path:
    """The batch in this process, with two math threads (a unit pins one, so this must not matter)."""
    import torch

    out = tmp_path_factory.mktemp("local") / "study"
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        code, log = _batch(speech_dir, out, tiny_assets)
    finally:
        torch.set_num_threads(before)
    assert code == 0, log
    return out


def _same_salt(local: Path, out: Path) -> None:
    (out / "key").mkdir(parents=True)
    shutil.copy2(local / "key" / "salt.txt", out / "key" / "salt.txt")


def test_a_batch_on_the_cluster_makes_the_same_study_as_here(ray_cluster, local_study, tiny_assets, speech_dir,
                                                             tmp_path):
    out = tmp_path / "study"
    _same_salt(local_study, out)
    code, log = _batch(speech_dir, out, tiny_assets, "--cluster", "auto")
    assert code == 0, log
    assert "4 video(s) to make on the Ray cluster at auto: 2 node(s), 2 CPU(s)" in log
    here = _motions(local_study)
    assert len(here) == 4 and _motions(out) == here                     # the motion behind each video, bytes
    assert (out / "key" / "conditions.csv").read_bytes() == (local_study / "key" / "conditions.csv").read_bytes()
    videos = sorted(p.name for p in (out / "videos").iterdir())
    assert videos == sorted(p.name for p in (local_study / "videos").iterdir())
    with open(out / "key" / "conditions.csv", newline="") as fh:
        key = [r["video"] for r in csv.DictReader(fh)]
    assert sorted(Path(v).with_suffix(".npz").name for v in key) == sorted(here)
    from gesturelsm.motion import MotionSequence

    for name in here:                                                    # each a BEAT2 motion as long as its speech
        m = MotionSequence.load(out / "key" / "motion" / name)
        assert m.fps == 30 and m.num_frames in (30, 36)
    code, log = _batch(speech_dir, out, tiny_assets, "--cluster", "auto")   # a rerun makes nothing
    assert code == 0 and "0 videos rendered, 4 already there" in log


def test_a_node_removed_mid_batch_still_gives_every_video_exactly_once(ray_cluster, local_study, tiny_assets,
                                                                       speech_dir, tmp_path):
    out = tmp_path / "study"
    _same_salt(local_study, out)
    worker_node = next(iter(ray_cluster.worker_nodes))
    removed = threading.Event()

    def remove_after_the_first_video() -> None:
        deadline = time.monotonic() + 600
        while time.monotonic() < deadline and not any((out / "videos").glob("v_*.mp4")):
            time.sleep(0.05)
        ray_cluster.remove_node(worker_node, allow_graceful=False)
        removed.set()

    watcher = threading.Thread(target=remove_after_the_first_video, daemon=True)
    watcher.start()
    try:
        code, log = _batch(speech_dir, out, tiny_assets, "--cluster", "auto")
        watcher.join(60)
    finally:
        if removed.is_set():
            ray_cluster.add_node(num_cpus=1, object_store_memory=100 * 2 ** 20)
            ray_cluster.wait_for_nodes()
    assert removed.is_set() and code == 0, log
    written = re.findall(r"(v_[0-9a-f]{10}\.mp4)  \(\d+ rendered\)", log)
    assert len(written) == 4 and len(set(written)) == 4                   # each video written once
    assert sorted(p.name for p in (out / "videos").iterdir()) == sorted(p.name for p in (local_study / "videos")
                                                                        .iterdir())
    assert _motions(out) == _motions(local_study)
    assert not [p for p in out.rglob("*") if p.name.endswith(".part")]    # nothing half-written


def _busy_workers() -> list[int]:
    """Ray worker processes running a unit (Ray titles a worker `ray::<function>` while it runs a task)."""
    pids = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if (d / "cmdline").read_bytes().startswith(b"ray::_remote_unit"):
                    pids.append(int(d.name))
            except OSError:
                continue
    return pids


def test_a_worker_killed_mid_batch_and_a_rerun_make_every_video_once(ray_cluster, local_study, tiny_assets,
                                                                   speech_dir, tmp_path):
    """A worker process making a video is killed (SIGKILL) mid-batch: its video is made again by a new worker and
    written once, the study is the one made here; a rerun into the same folder then makes nothing and changes
    nothing."""
    import os
    import signal

    out = tmp_path / "study"
    _same_salt(local_study, out)
    killed: list[int] = []

    def kill_a_busy_worker() -> None:
        deadline = time.monotonic() + 600
        while time.monotonic() < deadline and not killed:
            for pid in _busy_workers():
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    continue
                killed.append(pid)
                return
            time.sleep(0.05)

    killer = threading.Thread(target=kill_a_busy_worker, daemon=True)
    killer.start()
    code, log = _batch(speech_dir, out, tiny_assets, "--cluster", "auto")
    killer.join(60)
    assert killed and code == 0, log
    written = re.findall(r"(v_[0-9a-f]{10}\.mp4)  \(\d+ rendered\)", log)
    assert len(written) == 4 and len(set(written)) == 4                   # each video written once
    assert _motions(out) == _motions(local_study)
    files = {p: p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}
    code, log = _batch(speech_dir, out, tiny_assets, "--cluster", "auto")   # the rerun into the same folder
    assert code == 0 and "0 video(s) to make" in log and "0 videos rendered, 4 already there" in log, log
    assert {p: p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()} == files
    assert not [p for p in out.rglob("*") if p.name.endswith(".part")]
