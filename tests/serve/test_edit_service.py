"""The request service's edits (what the page's Edit section calls): a new result with one motion edited, the one
before it kept (files and all) for undo, chained edits, downloads of the edited motion, and one message per problem."""
from __future__ import annotations

import numpy as np
import pytest

from gesturelsm.errors import InputError
from gesturelsm.motion import MotionSequence
from gesturelsm.serve.editing import EDITED, edited_method, editable, root_folder
from gesturelsm.serve.config import ServiceSettings
from gesturelsm.serve.request import Request
from gesturelsm.serve.service import GestureService
from _support import speech_like


@pytest.fixture(scope="module")
def generated(tiny_pipeline, tmp_path_factory):
    service = GestureService(tiny_pipeline, ServiceSettings(workdir=str(tmp_path_factory.mktemp("edit_work"))))
    req = Request(None, methods=("gesturelsm", "ddim"), steps={"gesturelsm": 2, "ddim": 2}, render=False,
                  exports=False, transcribe=False)
    return service, service.run(req, audio=speech_like(6.0))


def test_an_edit_is_a_new_result_with_one_motion_changed_and_the_one_before_kept(generated):
    service, first = generated
    assert editable(service.pipeline, first) == ["gesturelsm", "ddim"]
    out = service.edit(first, "gesturelsm", 1.0, 3.0, ["hands", "upper"], 5)
    assert out.previous is first and edited_method(out) == "gesturelsm" and edited_method(first) is None
    assert out.motions["ddim"] is first.motions["ddim"]
    assert not np.array_equal(out.motions["gesturelsm"].poses, first.motions["gesturelsm"].poses)
    assert np.array_equal(out.motions["gesturelsm"].trans, first.motions["gesturelsm"].trans)      # lower kept
    assert out.job.folder.parent == first.job.folder and out.job.folder.is_dir()
    assert out.job.labels[0].endswith(EDITED) and not out.job.labels[1].endswith(EDITED)
    assert "**Edited:** GestureLSM: upper, hands 1.00-3.00 s, seed 5" in out.summary
    assert out.video is None and out.downloads == () and out.speech is first.speech and out.plan == first.plan


def test_edits_chain_undo_is_the_previous_result_and_downloads_follow_the_edit(generated):
    service, first = generated
    first = service.export(first)
    before = {p.name: p.read_bytes() for p in first.downloads}
    one = service.edit(first, "gesturelsm", 1.0, 3.0, ["upper"], 1)
    two = service.edit(one, "ddim", 2.0, 4.0, ["lower", "face"], 2)
    assert two.previous is one and one.previous is first and len(two.edits) == 2
    assert root_folder(two) == first.job.folder and two.job.folder.parent == first.job.folder
    assert two.motions["gesturelsm"] is one.motions["gesturelsm"]
    exported = service.export(two)
    npz = next(p for p in exported.downloads if p.name == "ddim.npz")
    assert npz.parent == two.job.folder
    assert np.array_equal(MotionSequence.load(npz).poses, two.motions["ddim"].poses)
    assert {p.name: p.read_bytes() for p in first.downloads} == before        # undo finds the original files


@pytest.mark.parametrize("args, message", [
    ((None, "gesturelsm", 1, 2, ["upper"], 0), "Generate first"),
    (("first", "ground_truth", 1, 2, ["upper"], 0), "Choose a shown motion to edit; the methods that can edit: "
                                                     "GestureLSM, DDIM"),
    (("first", "gesturelsm", None, 2, ["upper"], 0), "Give the time range to regenerate"),
    (("first", "gesturelsm", "soon", 2, ["upper"], 0), "Give the time range to regenerate"),
    (("first", "gesturelsm", 1, 2, ["upper"], "x"), "Seed must be a whole number from 0 to 4294967295 (got 'x')"),
    (("first", "gesturelsm", 1, 2, [], 0), "Choose at least one body region"),
    (("first", "gesturelsm", 1, 2, ["arms"], 0), "Unknown body region 'arms'"),
    (("first", "gesturelsm", 1, 2, ["upper"], -1), "Seed must be from 0 to 4294967295 (got -1)"),
    (("first", "gesturelsm", 1, 2, ["upper"], 1.5), "Seed must be a whole number from 0 to 4294967295 (got 1.5; "
                                                    "it is not rounded for you)"),
    (("first", "gesturelsm", 1, 2, ["upper"], 2**40), "Seed must be from 0 to 4294967295 (got 1099511627776)"),
    (("first", "gesturelsm", 1, 2, ["upper"], None), "Seed is empty"),
    (("first", "gesturelsm", 4, 9, ["upper"], 0), "the range 4-9 s of upper lies outside the speech (0-6.00 s)"),
    (("first", "gesturelsm", 3, 2, ["upper"], 0), "the range 3-2 s of upper is reversed"),
])
def test_each_problem_is_one_message(generated, args, message):
    service, first = generated
    args = (first if args[0] == "first" else args[0], *args[1:])
    with pytest.raises(InputError) as err:
        service.edit(*args)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_an_edit_shows_its_own_timings_beside_the_generation(generated, monkeypatch):
    """The generation's "Motion ready" figure stays after an edit; the edit has a row of its own (its stages, not the
    speech's again), and its video's render time goes in that row, the generation's video keeping its own."""
    import time
    from pathlib import Path

    import gesturelsm.serve.local as service_module

    def render_apart(motions, audio, video, **kw):          # a stand-in that takes a moment, as a render does
        time.sleep(0.01)
        Path(video).write_bytes(b"v")
    monkeypatch.setattr(service_module, "render_apart", render_apart)
    service, first = generated
    rendered = service.render(first)
    out = service.edit(rendered, "gesturelsm", 1.0, 3.0, ["hands"], 5)
    assert out.motion_seconds == first.motion_seconds
    assert "**Motion ready in " in out.summary and "**Edit made in " in out.summary
    assert [r.method for r in out.rows][:3] == ["GestureLSM", "DDIM", "GestureLSM, edit 1"]
    row = out.rows[2]
    assert row.sampling > 0 and row.features is None and row.transcription is None and row.rendering is None
    assert out.rows[-1].rendering == rendered.rows[-1].rendering                  # the generation's video's own time
    video = service.render(out)
    assert video.rows[2].rendering == round(video.edit_timings[-1].rendering, 3) and video.rows[2].rendering > 0
    assert video.rows[-1].rendering == rendered.rows[-1].rendering
    assert "Its video ready in" in video.summary
    two = service.edit(video, "ddim", 0.5, 1.0, ["upper"], 1)
    assert [r.method for r in two.rows][2:4] == ["GestureLSM, edit 1", "DDIM, edit 2"]
