"""The service composed behind one generation port (gesturelsm/serve/port.py): this process's generation and the
replicas' both are a `Generation`, the service hands every request, edit, sweep, video and download to the one it was
given; on replicas an edit is made on a replica (here a replica in this process behind a stand-in for Serve's handle
that pickles every call's values both ways, as Ray does); the live streams' busy signal reaches the runs made ahead
through the service; the request's folders are named in one module."""
from __future__ import annotations

import os
import pickle
import time
from collections import OrderedDict
from types import SimpleNamespace

import numpy as np
import pytest
import soundfile as sf

from _support import speech_like
from gesturelsm.serve.config import ServiceSettings
from gesturelsm.serve.editing import root_folder
from gesturelsm.serve.local import LocalGeneration
from gesturelsm.request_files import REQUEST_PREFIX, RequestFolders
from gesturelsm.serve.port import Generation
from gesturelsm.serve.replicas import GestureReplica, Scratch
from gesturelsm.serve.replicated import SWEEP_HERE, ReplicaGeneration, ReplicatedService
from gesturelsm.serve.request import Request
from gesturelsm.serve.service import GestureService

PORT = ("run", "stream", "edit", "render", "export", "sweep", "prefetch", "close")


class Handle:
    """Serve's handle to one replica, in this process: `handle.run.remote(...)` runs `replica.run` on copies of its
    values (pickled there and back, as Ray sends them) and records the call."""

    def __init__(self, replica: GestureReplica):
        self.replica, self.calls = replica, []

    def __getattr__(self, method: str):
        def remote(*args):
            self.calls.append(method)
            value = pickle.loads(pickle.dumps(getattr(self.replica, method)(*pickle.loads(pickle.dumps(args)))))
            return SimpleNamespace(result=lambda timeout_s=None: value, cancel=lambda: None)
        return SimpleNamespace(remote=remote)


@pytest.fixture(scope="module")
def front(tiny_pipeline, tmp_path_factory):
    """A page's service on one replica (in this process), and the replica's own service."""
    there = GestureService(tiny_pipeline, ServiceSettings(workdir=str(tmp_path_factory.mktemp("replica"))))
    replica = GestureReplica.__new__(GestureReplica)
    replica.scratch, replica.service, replica.characters = Scratch(tmp_path_factory.mktemp("scratch")), there, \
        OrderedDict()
    handle = Handle(replica)
    page = ServiceSettings(workdir=str(tmp_path_factory.mktemp("front")))
    return ReplicatedService(tiny_pipeline, page, None, handle=handle, count=None), handle, there


@pytest.fixture(scope="module")
def upload(tmp_path_factory):
    path = tmp_path_factory.mktemp("upload") / "speech.wav"
    sf.write(path, speech_like(6.0, seed=4), 16000)
    return str(path)


def _request(upload: str) -> Request:
    return Request(upload, methods=("gesturelsm",), steps={"gesturelsm": 2}, render=False, exports=False,
                   transcribe=False)


def test_both_generations_are_the_one_port_and_the_service_goes_through_it(tiny_pipeline, tmp_path, front):
    service = GestureService(tiny_pipeline, ServiceSettings(workdir=str(tmp_path)))
    replicated, _, _ = front
    assert isinstance(service.generation, LocalGeneration) and isinstance(service.generation, Generation)
    assert isinstance(replicated.generation, ReplicaGeneration) and isinstance(replicated.generation, Generation)
    assert type(replicated).run is GestureService.run and type(replicated).stream is GestureService.stream
    calls = []

    class Recording:
        where, sweep_note = "elsewhere", "sweeps elsewhere"

        def __init__(self, local):
            self.local = local

        def __getattr__(self, method):
            return lambda *a, **k: calls.append(method) or (iter([]) if method == "stream" else "out")
    other = GestureService(tiny_pipeline, ServiceSettings(workdir=str(tmp_path)), generation=Recording)
    assert isinstance(other.generation, Generation) and other.generation.local is other.local
    other.run(Request(None))
    list(other.stream(Request(None)))
    other.edit(None, "gesturelsm", 0, 1, ["upper"], 0)
    other.export(None)
    other.sweep(None)
    other.prefetch("speech.wav")
    other.close()
    assert calls == ["run", "stream", "edit", "export", "sweep", "prefetch", "close"]
    assert (service.where, replicated.where, other.where) == ("this process", "replicas", "elsewhere")
    assert (service.generation.sweep_note, replicated.generation.sweep_note) == ("", SWEEP_HERE)


def test_an_edit_on_replicas_is_made_on_a_replica_the_same_as_here(front, upload):
    service, handle, there = front
    first = service.run(_request(upload))
    assert handle.calls == ["run"] and first.job.folder.parent == service.workdir
    assert list(service.stream(_request(upload)))[-1].motions.keys() == first.motions.keys()   # one result, whole
    edited = service.edit(first, "gesturelsm", 1.0, 3.0, ["upper"], 7)
    assert handle.calls[-1] == "edit" and edited.previous is first and root_folder(edited) == first.job.folder
    assert edited.job.folder.parent == first.job.folder and edited.job.folder.is_dir() and len(edited.edits) == 1
    here = there.edit(first, "gesturelsm", 1.0, 3.0, ["upper"], 7)           # the same edit in this process
    np.testing.assert_array_equal(edited.motions["gesturelsm"].poses, here.motions["gesturelsm"].poses)
    assert not np.array_equal(edited.motions["gesturelsm"].poses, first.motions["gesturelsm"].poses)
    again = service.edit(edited, "gesturelsm", 4.0, 5.0, ["hands"], 1)       # edits chain, each on a replica
    assert handle.calls[-1] == "edit" and again.previous is edited and len(again.edits) == 2
    assert again.job.folder.parent == first.job.folder and again.job.folder != edited.job.folder
    files = service.export(edited)                                           # its downloads land in its folder
    assert handle.calls[-1] == "export" and {p.parent for p in files.downloads} == {edited.job.folder}
    assert all(p.is_file() for p in files.downloads)


def test_the_live_streams_busy_signal_reaches_the_runs_made_ahead_through_the_service(tiny_pipeline, tmp_path):
    live = [False]
    service = GestureService(tiny_pipeline, ServiceSettings(workdir=str(tmp_path)), busy=lambda: live[0])
    streams = [0]
    service.set_busy(lambda: streams[0] > 0)
    assert not service.busy() and not service.ahead.busy()
    for signal in (live, streams):
        signal[0] = 1
        assert service.busy() and service.ahead.busy()
        assert service.ahead.start("key", lambda run: iter(())) is None      # nothing is made ahead meanwhile
        signal[0] = 0
    run = service.ahead.start("key", lambda run: iter(()))
    assert run is not None
    run.thread.join(10)
    assert run.done and not run.failed


def test_request_folders_are_named_and_swept_in_one_place(tmp_path):
    folders = RequestFolders(tmp_path, keep_minutes=1)
    new = folders.new()
    assert new.parent == tmp_path and new.name.startswith(REQUEST_PREFIX) and len(new.name) == len(REQUEST_PREFIX) + 32
    old = folders.new()
    os.utime(old, (time.time() - 120, time.time() - 120))
    (tmp_path / "player-bodies").mkdir()                                     # not a request's: kept
    assert folders.cleanup() == 1 and new.is_dir() and not old.exists() and (tmp_path / "player-bodies").is_dir()
