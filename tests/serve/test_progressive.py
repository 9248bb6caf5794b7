"""A request's result as it grows (gesturelsm/serve/progressive.py, `GestureService.stream`), on tiny checkpoints:
one result once the speech is prepared and one per method made, fastest first, in the page's order, ending where
`run` ends; a method that fails leaves the others (said in the result), and the page's player payload grows with it."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.errors import GestureError, InputError
from gesturelsm.pipeline import GROUND_TRUTH, Plan
from gesturelsm.serve.request import Request
from gesturelsm.settings import Settings

ALL = ["gesturelsm", "rectified_flow", "ddim"]
STEPS = {"gesturelsm": 3, "rectified_flow": 1, "ddim": 2}


def _request(wav, methods=ALL, **kw) -> Request:
    return Request(str(wav), methods=methods, steps=dict(STEPS), exports=False, render=False, **kw)


def test_the_pipeline_makes_the_fewest_steps_first_and_reports_failures(tiny_pipeline, monkeypatch):
    from _support import speech_like

    speech = tiny_pipeline.prepare_speech(speech_like(2.0), transcribe=False)
    plan = Plan(Settings(tuple(ALL), dict(STEPS)))
    assert tiny_pipeline.run_order(plan) == ["rectified_flow", "ddim", "gesturelsm"]
    assert tiny_pipeline.run_order(Plan(Settings(tuple(ALL)))) == ALL        # equal steps: the plan's order
    each = [x.method for x in tiny_pipeline.generate_each(speech, plan)]
    assert each == ["rectified_flow", "ddim", "gesturelsm"]
    whole = {x.method: x.motion for x in tiny_pipeline.generate_each(speech, plan)}

    def boom(*a, **k):
        raise RuntimeError("boom")
    monkeypatch.setattr(tiny_pipeline.backends["ddim"], "generate", boom)
    made = list(tiny_pipeline.generate_each(speech, plan, keep_going=True))
    assert [x.method for x in made] == ["rectified_flow", "ddim", "gesturelsm"]
    assert made[1].motion is None and str(made[1].error) == "boom"
    np.testing.assert_array_equal(made[2].motion.poses, whole["gesturelsm"].poses)   # the others as before
    with pytest.raises(RuntimeError, match="boom"):
        list(tiny_pipeline.generate_each(speech, plan))


def test_a_request_grows_method_by_method_and_ends_as_run_does(service, speech_wav):
    results = [r for r in service.stream(_request(speech_wav)) if not r.previews]   # previews: test_previews.py
    assert [list(r.motions) for r in results] == [[], ["rectified_flow"], ["rectified_flow", "ddim"], ALL]
    assert [r.pending for r in results] == [tuple(ALL), ("gesturelsm", "ddim"), ("gesturelsm",), ()]
    assert all(r.slots == results[0].slots for r in results) and [m for m, _ in results[0].slots] == ALL
    assert results[0].slots[0][1] == "GestureLSM 3 steps CFG 2"
    assert [len(r.rows) for r in results] == [1, 2, 3, 4]                  # a timing row per method made, then total
    assert len({r.job.folder for r in results}) == 1 and results[-1].failed == {}
    assert "Generating:" in results[1].summary and "Generating:" not in results[-1].summary
    whole = service.run(_request(speech_wav))
    for m in ALL:
        np.testing.assert_array_equal(results[-1].motions[m].poses, whole.motions[m].poses)


def test_a_failing_method_leaves_the_others_and_is_said(service, speech_wav, monkeypatch):
    def boom(*a, **k):
        raise RuntimeError("a bug")

    def refused(*a, **k):
        raise InputError("DDIM cannot do that here")
    monkeypatch.setattr(service.pipeline.backends["ddim"], "generate", boom)
    out = list(service.stream(_request(speech_wav)))[-1]
    assert list(out.motions) == ["gesturelsm", "rectified_flow"] and out.pending == ()
    assert out.failed == {"ddim": "it failed on the server"}
    assert "DDIM: it failed on the server" in out.summary
    monkeypatch.setattr(service.pipeline.backends["ddim"], "generate", refused)
    assert service.run(_request(speech_wav)).failed == {"ddim": "DDIM cannot do that here"}
    with pytest.raises(InputError, match="DDIM cannot do that here"):         # the only method: its own message
        service.run(_request(speech_wav, methods=["ddim"]))
    monkeypatch.setattr(service.pipeline.backends["gesturelsm"], "generate", boom)
    with pytest.raises(GestureError, match="GestureLSM: it failed on the server; DDIM: DDIM cannot do that here"):
        service.run(_request(speech_wav, methods=["gesturelsm", "ddim"]))


def test_ground_truth_of_unknown_speech_has_no_place(service, speech_wav):
    results = list(service.stream(_request(speech_wav, methods=["gesturelsm", GROUND_TRUTH])))
    assert [m for m, _ in results[0].slots] == ["gesturelsm"] and results[0].pending == ("gesturelsm",)
    assert any("not a take" in w for w in results[-1].warnings) and list(results[-1].motions) == ["gesturelsm"]


def test_a_service_that_makes_results_elsewhere_gives_one(service, speech_wav):
    """A service whose results are made elsewhere (the replicas' generation, serve/replicated.py, which answers once
    every method is made): the page gets that one result, made once."""
    from gesturelsm.serve.replicated import ReplicaGeneration
    from gesturelsm.serve.service import GestureService

    made = []

    class Elsewhere(ReplicaGeneration):
        def run(self, req, progress=None, audio=None):
            made.append(req)
            return self.local.run(req, progress, audio)
    other = GestureService(service.pipeline, service.settings, service.body,
                           generation=lambda local: Elsewhere(local, handle=None, count=None))
    results = list(other.stream(_request(speech_wav)))
    assert len(results) == 1 and len(made) == 1 and list(results[0].motions) == ALL
    assert results[0].pending == () and results[0].video is None


def test_requests_generate_at_the_servers_math_threads(service, speech_wav, monkeypatch):
    """Each request generates at `ServiceSettings.threads` in the thread that serves it, whatever that thread had."""
    from dataclasses import replace

    import torch

    from gesturelsm.serve.service import GestureService

    seen = []
    generate = service.pipeline.backends["ddim"].generate

    def recorded(*a, **k):
        seen.append(torch.get_num_threads())
        return generate(*a, **k)
    monkeypatch.setattr(service.pipeline.backends["ddim"], "generate", recorded)
    before = torch.get_num_threads()
    try:
        for n in (2, 1):
            torch.set_num_threads(3 - n)
            other = GestureService(service.pipeline, replace(service.settings, threads=n), service.body)
            other.run(_request(speech_wav, methods=["ddim"], transcribe=False))   # one generation per request (words
            # recognised alongside generation that turn out not to be used start it again: gesturelsm/pipelined.py)
    finally:
        torch.set_num_threads(before)
    assert seen == [2, 1]
