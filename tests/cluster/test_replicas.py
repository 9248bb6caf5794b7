"""The web demo on Ray Serve replicas (`python -m app --replicas N`) over a simulated two-node cluster: the page, one
front end, serves concurrent API requests through two replicas, still when one replica is killed during them (its
call is made again on another, with the same motion for the same seed), and the dead replica's folder goes away.
Too few CPUs for the replicas is one line, before any model is loaded."""
from __future__ import annotations

import os
import signal
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from gesturelsm.cluster import parse_cluster, parse_replicas
from gesturelsm.serve.replicas import SCRATCH, Upload

from _support import gradio_client, served, speech_like, until

AUTO = parse_cluster("auto")
SCRATCH_ROOT = Path(tempfile.gettempdir()) / SCRATCH
pids_seen: set[int] = set()                 # every replica these tests saw, for the check after they stop


def _settings(assets: Path, workdir: Path):
    from gesturelsm.serve.config import ServiceSettings

    return ServiceSettings(checkpoints=str(assets), workdir=str(workdir), max_seconds=20, render_nice=0)


def test_too_few_cpus_for_the_replicas_is_one_line_before_loading(ray_cluster, tiny_assets, tmp_path, capsys):
    import ray

    from gesturelsm.commands.serve import main

    t0 = time.perf_counter()
    code = main(["--replicas", "3", "--cluster", "auto", "--checkpoints", str(tiny_assets), "--workdir",
                 str(tmp_path), "--no-warmup", "--port", "0"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and err[-1] == ("python -m app: error: --replicas 3 needs 3 CPU(s) but the Ray cluster at auto: "
                                     "2 node(s), 2 CPU(s) has 2: ask for less, or add nodes (`ray start "
                                     "--address=HEAD:6379` on another machine)")
    assert time.perf_counter() - t0 < 60 and not ray.is_initialized()
    assert main(["--cluster", "auto", "--port", "0"]) == 2
    assert capsys.readouterr().err.strip().endswith("--cluster says where replicas run: give --replicas N too")


@pytest.fixture(scope="module")
def replicated(ray_cluster, tiny_assets, tmp_path_factory):
    from gesturelsm.serve.replicated import ReplicatedService

    service = ReplicatedService.start(_settings(tiny_assets, tmp_path_factory.mktemp("front")), parse_replicas("2"),
                                      AUTO, warmup=False)
    try:
        yield service
    finally:
        service.close()
    left = [p.name for p in SCRATCH_ROOT.glob("replica-*") if int(p.name.split("-")[1]) in pids_seen]
    assert left == [], f"stopped replicas left their folders: {left}"


def _replica_pids() -> list[int]:
    import ray._private.state

    pids = sorted(a["Pid"] for a in ray._private.state.actors(actor_state_name="ALIVE").values()
                  if "GestureReplica" in a["Name"])
    pids_seen.update(pids)
    return pids


def test_four_visitors_through_two_replicas_one_killed_meanwhile(replicated, tiny_assets, tmp_path):
    from gradio_client import handle_file

    from gesturelsm.serve.request import Request
    from gesturelsm.serve.service import GestureService

    wav = tmp_path / "speech.wav"
    sf.write(wav, speech_like(1.5, seed=4), 16000)
    assert replicated.settings.concurrency == 2                     # two replicas, one request each
    pids = _replica_pids()
    assert len(pids) == 2
    scratch = SCRATCH_ROOT
    killed_folders = sorted(p.name for p in scratch.glob(f"replica-{pids[0]}-*"))
    assert len(killed_folders) == 1
    seeds = [0, 1, 0, 1]
    with served(replicated) as url:
        jobs = [gradio_client(url).submit(handle_file(str(wav)), "", None, ["gesturelsm"], 1, 2.0, seed, 20, False,
                                          "off", 256, False, api_name="/generate") for seed in seeds]
        until(lambda: all(any(scratch.glob(f"replica-{pid}-*/call-*")) for pid in pids),
              "both replicas were working on a request", limit=600)
        os.kill(pids[0], signal.SIGKILL)
        answers = [j.result(timeout=900) for j in jobs]
    motions = []
    for video, rows, summary, files, glb in answers:
        assert Path(video).is_file() and Path(video).stat().st_size > 1000
        npz = next(Path(f) for f in files if Path(f).name == "gesturelsm.npz")
        with np.load(npz) as d:
            motions.append(d["poses"].copy())
    # (each request's own folder is not visible here: Gradio serves files from a cache named by their content, and the
    # same seed's video can be the same bytes; tests/cluster's crowd test counts the front end's request folders)
    here = GestureService(replicated.pipeline, replicated.settings, replicated.body)
    for seed, got in zip(seeds, motions):                          # the same motion as this process makes
        want = here.run(Request(str(wav), methods=["gesturelsm"], steps=1, cfg=2.0, seed=seed, smoothing="off",
                                render=False, exports=False, transcribe=False)).motions["gesturelsm"]
        np.testing.assert_allclose(got, want.poses, atol=1e-5)
    assert not np.allclose(motions[0], motions[1])
    until(lambda: not any(scratch.glob(killed_folders[0])), "the killed replica's replacement removed its folder",
          limit=300, every=0.5)
    assert len(_replica_pids()) == 2 and pids[0] not in _replica_pids()


def test_a_visitors_error_comes_back_as_one_line(replicated, tmp_path):
    from gesturelsm.errors import InputError
    from gesturelsm.serve.request import Request

    silent = tmp_path / "silent.wav"
    sf.write(silent, np.zeros(16000, np.float32), 16000)
    with pytest.raises(InputError, match="silent"):
        replicated.run(Request(str(silent), methods=["gesturelsm"], transcribe=False))
    with pytest.raises(InputError, match="Unknown method"):        # checked here, no replica asked
        replicated.run(Request(str(silent), methods=["nope"]))


def test_a_prefetched_transcript_goes_with_the_request(replicated, tmp_path):
    """The page asks a replica to transcribe an upload while the visitor chooses the settings; the request then
    carries those words, so whichever replica makes it does not transcribe again."""
    from gesturelsm.serve.request import Request

    wav = tmp_path / "speech.wav"
    sf.write(wav, speech_like(2.0, seed=7), 16000)
    assert replicated.prefetch(str(wav)) is True
    assert replicated.prefetch(None) is False
    out = replicated.run(Request(str(wav), methods=["gesturelsm"], render=False, exports=False))
    remembered = replicated.generation._remembered(Upload(wav.name, wav.read_bytes()))
    assert remembered is not None and out.text_mode == remembered.text_mode
    assert remembered.seconds > 0                                      # the recognition's own time, on the replica
    assert out.timings["gesturelsm"]["transcription"] == remembered.seconds     # found ready, not recognised again
    assert out.rows[-1].method.endswith("words recognised earlier")


CLIENT = """
import sys
from gradio_client import Client, handle_file
Client(sys.argv[1], verbose=False, httpx_kwargs={"timeout": 120}).predict(
    handle_file(sys.argv[2]), "", None, ["gesturelsm"], 1, 2.0, 7, 20, False, "off", 256, False, api_name="/generate")
"""


def test_a_client_killed_mid_request_leaves_the_others_and_the_replicas_as_they_were(replicated, tmp_path):
    """An API client process killed (SIGKILL) while a replica makes its request: the call ends on the replica as
    any other (its folder removed), no replica dies, and three clients sent meanwhile each get their own motion."""
    import subprocess
    import sys

    from gradio_client import handle_file

    wav = tmp_path / "speech.wav"
    sf.write(wav, speech_like(1.5, seed=5), 16000)
    pids = _replica_pids()
    before = {p.name for pid in pids for p in SCRATCH_ROOT.glob(f"replica-{pid}-*/call-*")}
    with served(replicated) as url:
        client = subprocess.Popen([sys.executable, "-c", CLIENT, url, str(wav)], stdout=subprocess.DEVNULL,
                                  stderr=subprocess.DEVNULL)
        try:
            def reached() -> bool:
                assert client.poll() is None, "the client ended before its request reached a replica"
                return bool({p.name for pid in pids for p in SCRATCH_ROOT.glob(f"replica-{pid}-*/call-*")} - before)
            until(reached, "the killed client's request reached a replica", limit=600)
        finally:
            client.kill()                                            # mid-request
            client.wait()
        jobs = [gradio_client(url).submit(handle_file(str(wav)), "", None, ["gesturelsm"], 1, 2.0, seed, 20, False,
                                          "off", 256, False, api_name="/generate") for seed in (0, 1, 2)]
        answers = [j.result(timeout=900) for j in jobs]
    motions = []
    for video, rows, summary, files, glb in answers:
        npz = next(Path(f) for f in files if Path(f).name == "gesturelsm.npz")
        with np.load(npz) as d:
            motions.append(d["poses"].copy())
    assert len({str(Path(a[0]).parent) for a in answers}) == 3                        # three folders
    assert not np.allclose(motions[0], motions[1]) and not np.allclose(motions[1], motions[2])
    until(lambda: not any(p for pid in pids for p in SCRATCH_ROOT.glob(f"replica-{pid}-*/call-*")),
          "every call ended on the replicas, the killed client's too", limit=300, every=0.5)
    assert _replica_pids() == pids                                   # no replica died or was replaced


CROWD = 12                                  # API clients at once on the two replicas (benchmarks/replicas_crowd.py: 20)


def _outcome(job):
    """A client's answer, or the one line it was refused with (never a traceback)."""
    try:
        return job.result(timeout=1800)                              # bounds a hang; never reached when all is well
    except Exception as exc:                                        # gradio_client's AppError: the server's gr.Error
        return exc


def test_twelve_clients_on_two_replicas_one_killed_each_gets_its_own_motion(replicated, tmp_path):
    """Twelve API clients at once, each with its own seed, and a replica killed while both make a request: every
    client gets the motion this process makes for its seed (the killed replica's request made again on the other),
    in a folder of its own; the front end keeps serving; no call folder is left on the replicas, the dead one's goes
    with it; one request folder here per answer."""
    from gradio_client import handle_file

    from gesturelsm.serve.request import Request
    from gesturelsm.serve.service import GestureService

    wav = tmp_path / "speech.wav"
    sf.write(wav, speech_like(1.5, seed=6), 16000)
    pids = _replica_pids()
    killed = sorted(p.name for p in SCRATCH_ROOT.glob(f"replica-{pids[0]}-*"))
    front = replicated.workdir
    before = set(front.glob("req-*"))
    seeds = list(range(100, 100 + CROWD))
    with served(replicated) as url:
        clients = [gradio_client(url) for _ in seeds]
        jobs = [c.submit(handle_file(str(wav)), "", None, ["gesturelsm"], 1, 2.0, seed, 20, False, "off", 256, False,
                         api_name="/generate") for c, seed in zip(clients, seeds)]
        until(lambda: all(any(SCRATCH_ROOT.glob(f"replica-{pid}-*/call-*")) for pid in pids),
              "both replicas were working on a request", limit=600)
        os.kill(pids[0], signal.SIGKILL)                            # mid-request, with ten more waiting
        outcomes = [_outcome(j) for j in jobs]
        after_kill = gradio_client(url).predict(handle_file(str(wav)), "", None, ["gesturelsm"], 1, 2.0, 999, 20,
                                                False, "off", 256, False, api_name="/generate")
        made = set(front.glob("req-*")) - before                    # (the page's close empties the folder)
    refused = [str(o) for o in outcomes if isinstance(o, Exception)]
    assert refused == [], refused                                   # the killed replica's request was made again
    here = GestureService(replicated.pipeline, replicated.settings, replicated.body)
    for seed, (video, rows, summary, files, glb) in zip(seeds, outcomes):
        assert Path(video).is_file()
        npz = next(Path(f) for f in files if Path(f).name == "gesturelsm.npz")
        with np.load(npz) as d:
            got = d["poses"].copy()
        want = here.run(Request(str(wav), methods=["gesturelsm"], steps=1, cfg=2.0, seed=seed, smoothing="off",
                                render=False, exports=False, transcribe=False)).motions["gesturelsm"]
        np.testing.assert_allclose(got, want.poses, atol=1e-5)      # its own seed's motion, nobody else's
    assert Path(after_kill[0]).is_file()                            # the front end stayed up
    assert len({str(Path(o[0]).parent) for o in outcomes}) == CROWD              # twelve videos, twelve files
    assert len(made) == CROWD + 1                                   # a request folder per answer, none else

    def calls() -> list[Path]:
        return [p for pid in pids_seen for p in SCRATCH_ROOT.glob(f"replica-{pid}-*/call-*")]

    until(lambda: not any(SCRATCH_ROOT.glob(killed[0])) and calls() == [],
          "the replacement removed the killed replica's folder and every call ended", limit=300, every=0.5)
    assert len(_replica_pids()) == 2 and pids[0] not in _replica_pids()
