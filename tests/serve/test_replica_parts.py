"""The parts of the demo's replicas that need no cluster (serve/replicas.py, serve/replicated.py): Serve's options for
a fixed or scaled count, Ray's configuration accepting them, scratch folders of dead replicas found by their lock,
and a replica's files landing in the visitor's folder with the result pointing at them."""
from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest

from gesturelsm.cluster import parse_replicas
from gesturelsm.serve.replicas import REPLICA_CPUS, Scratch, serve_options, sweep_dead


def test_serve_options_for_a_fixed_and_a_scaled_count():
    fixed = serve_options(parse_replicas("3"), per_replica=2)
    assert fixed["num_replicas"] == 3 and "autoscaling_config" not in fixed
    assert fixed["max_ongoing_requests"] == 2 and fixed["ray_actor_options"] == {"num_cpus": REPLICA_CPUS}
    scaled = serve_options(parse_replicas("2:8"), per_replica=1)
    assert "num_replicas" not in scaled
    assert scaled["autoscaling_config"] == dict(min_replicas=2, max_replicas=8, target_ongoing_requests=1,
                                                upscale_delay_s=5, downscale_delay_s=120)
    from ray.serve.config import AutoscalingConfig                      # Serve accepts them as they are

    AutoscalingConfig(**scaled["autoscaling_config"])


def test_the_scratch_of_a_dead_replica_is_removed_and_a_live_ones_kept(tmp_path):
    live = Scratch(tmp_path)
    assert live.folder.parent == tmp_path and live.folder.name.startswith("replica-") and live.removed == 0
    (live.call_folder() / "x.mp4").write_bytes(b"video")
    code = f"import sys; sys.path[:0] = {sys.path!r}; from gesturelsm.serve.replicas import Scratch; " \
           f"print(Scratch({str(tmp_path)!r}).folder)"
    dead = Path(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip())
    assert dead.is_dir() and dead != live.folder                    # its process ended: its lock is free
    assert sweep_dead(tmp_path) == 1
    assert not dead.exists() and live.folder.is_dir() and len(list(live.folder.glob("call-*/x.mp4"))) == 1
    again = Scratch(tmp_path)
    assert again.removed == 0                                       # nothing else dead
    again.close()                                                   # a replica stopped in order leaves nothing
    assert sorted(p.name for p in tmp_path.iterdir()) == [live.folder.name]


def test_a_replicas_files_land_in_the_visitors_folder(tmp_path):
    import numpy as np

    from gesturelsm.serve.replicas import Reply
    from gesturelsm.serve.replicated import _receive
    from gesturelsm.serve.request import RenderJob, Result

    there = tmp_path / "replica" / "req-1"
    here = tmp_path / "front" / "req-2"
    here.mkdir(parents=True)
    job = RenderJob(there, (), (), (), np.zeros(10, np.float32), 1.0, 256, 0.0)
    result = Result(there / "gestures.mp4", [], (there / "m.npz", Path("/elsewhere/kept.txt")), there / "m.glb",
                    "audio-only", (), None, 1.0, 1.0, {}, {}, None, job)
    got = _receive(Reply(result, {"gestures.mp4": b"mp4", "m.npz": b"npz", "m.glb": b"glb"}, elapsed=2.5), here)
    assert got.video == here / "gestures.mp4" and got.video.read_bytes() == b"mp4"
    assert got.downloads == (here / "m.npz", Path("/elsewhere/kept.txt")) and got.glb.read_bytes() == b"glb"
    assert got.job.folder == here and got.job.started == pytest.approx(time.perf_counter() - 2.5, abs=1)
    assert sorted(p.name for p in here.iterdir()) == ["gestures.mp4", "m.glb", "m.npz"]


def test_a_request_reaches_a_replica_with_its_missing_fields_still_missing():
    """A request travels to a replica pickled (Ray's cloudpickle); a field the page left MISSING (each method's own
    steps) must arrive as the same MISSING, or the replica's checks read it as a value sent and refuse it."""
    import pickle

    from ray import cloudpickle

    from gesturelsm.serve.request import Request
    from gesturelsm.settings import MISSING

    req = Request("speech.wav", methods=["gesturelsm", "ddim"])
    for dumps, loads in ((pickle.dumps, pickle.loads), (cloudpickle.dumps, cloudpickle.loads)):
        got = loads(dumps(req))
        assert got.steps is MISSING and got.ddim_steps is MISSING and got == req


def test_stopping_replicas_on_a_cluster_this_process_started_leaves_serve_to_the_cluster(monkeypatch):
    """`--cluster local`: the cluster goes next (ray.shutdown), Serve with it; shutting Serve down on its own first made
    Ray print "(raylet) Task ServeController.graceful_shutdown failed ... retried" at every stop. A joined cluster keeps
    running, so Serve is shut down there once no application is left (the subprocess check: test_app_process.py)."""
    from types import SimpleNamespace

    from ray import serve

    from gesturelsm.serve import replicas
    from gesturelsm.serve.replicated import ReplicaGeneration

    calls = []
    monkeypatch.setattr(serve, "delete", lambda name: calls.append(("delete", name)))
    monkeypatch.setattr(serve, "shutdown", lambda: calls.append(("shutdown",)))
    monkeypatch.setattr(serve, "status", lambda: SimpleNamespace(applications={}))
    for owned, want in ((True, [("delete", "app-1")]), (False, [("delete", "app-1"), ("shutdown",)])):
        calls.clear()
        closed = []
        generation = ReplicaGeneration.__new__(ReplicaGeneration)
        generation.name, generation.connection = "app-1", SimpleNamespace(owned=owned, close=lambda: closed.append(1))
        generation.close()
        assert calls == want and closed == [1]
    calls.clear()
    replicas.stop("app-2")                              # by default (a joined cluster): Serve goes when it is empty
    assert calls == [("delete", "app-2"), ("shutdown",)]
